"""Golden fingerprints of the items model: the same bytes from the same config and seeds.

Short runs of each mode, truth and algorithm family and of options that change the trajectory;
each per-trial summary column and each per-robot column must give exactly these SHA-256 digests
(of the little-endian array bytes). A speed-up must keep them; an intentional change of the
model's numbers regenerates them with :func:`digests` and pastes the dict here.
"""

import hashlib

import numpy as np
import pytest

from dronefleet.items import Params, simulate

RUNS = {
    "fp_poisson_gr": Params(trials=3, steps=400),
    "fp_bernoulli_cas_rate": Params(truth="bernoulli", algorithm="CAS", cas_variant="rate", n_robots=7, trials=3,
                                    steps=400),
    "fp_poisson_r_private": Params(algorithm="R", sharing="destinations", capacity=4, trials=3, steps=400),
    "fp_logistic_astc": Params(truth="logistic", algorithm="ASTC", n_robots=8, sigma_e=0.12, trials=3, steps=400),
    "fp_logistic_sf": Params(truth="logistic", algorithm="SF", n_robots=25, sigma_e=0.2, trials=2, steps=400),
    "idp_gric_mu": Params(mode="delivery", algorithm="GRIC", lam_hat_source="mu", n_robots=6, trials=2, steps=300),
    "idp_gr_coarse": Params(mode="delivery", algorithm="GR", grid_spacing=0.1, speed=0.4, gr_cap="max", trials=2,
                            steps=300, truncation="resample"),
}

EXPECTED = {'fp_bernoulli_cas_rate': {'robots.items': '2c83133316a56f6aeab06389c9fa097c11a5e55f427105a2e0ac7373a0d9d0b9',
                           'robots.robot': '454dd723f251a585f455c1c674acef15a3ce9ffa615555648d1dc83a45d5a0a5',
                           'robots.trial': 'b45bdf057d4d314c437b61294b490681bcdf435eddf1512b2de952b9d5cad5c4',
                           'robots.trips': '7f2ccbccdf7d96a23faba0f6a9fb220ec7569df19d038d9f8b10e08c8aa2c482',
                           'robots.visits': 'f2335e5457b0bd25fa299240dc1dc1fb21f518ef50bdc1c48ffc34ccda2ce2e6',
                           'summary.generated': '34c0150d667707df35b4dab149897980713e23ca42b12a49aef1687b6e399e4a',
                           'summary.items_per_trip': 'b41c0225c3e96e18e870c81c42a8e9af6d4a01a6be55dc780639fc5a92ee069f',
                           'summary.picked': '6866f7d141d14e7c1d6b6c99b007d9d1f39aa9862e67fdab2d505e752ef48e92',
                           'summary.rate': '4f406ee4edbd34ceab8155fa5e126ccb5adfa47b1a6182ce72741d234f2edc76',
                           'summary.seed': 'bd00ef1c87db2cc1d54852586f600c10d62e9d4ca1887196ce2d0eecd91082f6',
                           'summary.served': '31fef908466d7d9054b84fe8c7f19a1809d43ad184c7afb040cc32c8716a5000',
                           'summary.trial': 'e2e2033ae7e19d680599d4eb0a1359a2b48ec5baac75066c317fbf85159c54ef',
                           'summary.trips': 'a7033941a549b06c15e4e194290547589f377343ab329c92dd75594b6bc74630',
                           'summary.visits': '6dbcd2d1144d8ff927b98b4b8c706ae5af2af0622fde2553becd3e1defce208f'},
 'fp_logistic_astc': {'robots.items': 'da16a4d02d5ef0d6b807c5cd5f38824743739f77f8aa0c925335f78d44f9b39f',
                      'robots.robot': '2f2a315d65745d62ffdeac4f6af64c1e41186ef0c0686a97d3fc35b67fdd8ea4',
                      'robots.trial': 'dd0c47aa13715a93790b536abf5b52308040217345bfca588e530bbee6dcd8c6',
                      'robots.trips': '543fd04c81bb3bfda8097f38fc992555056df41a41b62538f4211ee0474be2a8',
                      'robots.visits': '69a4523ae0a121361d3384415d9eb2c80e44ef25ea46d15e1f397ee4ba23a0f9',
                      'summary.generated': 'ba6c5955ff5d4be67fe174634c3676d85860802f09ae3558e6104333af0697b4',
                      'summary.items_per_trip': '678efff081bcb73f6922899c4e7532347c45f91e775a3697a940833057022f23',
                      'summary.picked': '9c4501efb808d2631284039839ba37fa7f562d081ac04b6cc2e221df0226d899',
                      'summary.rate': '9512dd6f1903096808af3db517bab25a3687451b9324825f0f26463757787564',
                      'summary.seed': 'bd00ef1c87db2cc1d54852586f600c10d62e9d4ca1887196ce2d0eecd91082f6',
                      'summary.served': '98580a7b9299e1f1b151efa8fe52a3fff4e92cd072988a331f773be800bced6a',
                      'summary.trial': 'e2e2033ae7e19d680599d4eb0a1359a2b48ec5baac75066c317fbf85159c54ef',
                      'summary.trips': '6ffe277614089c54787216e7b61ade560eb4ac4aee791471bc1d42c82e355b6a',
                      'summary.visits': 'ed7c07f05047dcf195b5f0c72e4175da676aca31f6d43ff8dffa563f06d9c2c7'},
 'fp_logistic_sf': {'robots.items': '0108f8bce630ee158baf64a78c608891ffcc24b1f5dcf03c37cfa5872e407a7a',
                    'robots.robot': '874ca590b22db7c00a520ad54b409c9a5ef58c64d61ac86503af98ce96295f9d',
                    'robots.trial': '0a5bf405ee56c7474999de64a7469e75ab3fa5a85ffe339cf93f00c5875ade66',
                    'robots.trips': 'e00dc32e4ee714a912aee400326363ecf9127e6f4d98d23370bd67e703d57715',
                    'robots.visits': '493ef51ea884a047e89976bf8dd40c257edd08df2b5bca895f3d9fc748048bb5',
                    'summary.generated': 'a5782ef08b345c687b285c0f06dcfa7b9ec9b15fa664242a0b70fef9d80edaed',
                    'summary.items_per_trip': '63e66947812d7d505b909a743c3db9b647d2853f5eb1b77d9691da17cd708b8f',
                    'summary.picked': 'c975f709f19356dc7754f27da2f8ba8c8e498532d9f412285f8ad2d0445d7032',
                    'summary.rate': 'd201b88a2b5a52c897b8d26b39640681ef97856469fa4570ff4119fa0ce32099',
                    'summary.seed': '9e6ed801146fe33aa91bb80ed0e1f0700e6068af7e44f54236ca65254358d530',
                    'summary.served': '5dbe188234d182f0a7efe43ffb173a417d7f4ecb4c2dc6f6e59b1e28bfb5d591',
                    'summary.trial': '0c730b69905c5ef7a4ca5269f72365400bde2dd2c04eaf9bbb3d1c4a265a0131',
                    'summary.trips': 'c7368002ba176f6dc599eae43f94df1d26e178de37736341a525fb8dd05a9744',
                    'summary.visits': '202db9d7f7dcbf850bc420370c90d7106bba82a1d793662d1bd3b70fbf496b7a'},
 'fp_poisson_gr': {'robots.items': '1e96fc57c4d679b9df73a053de29aa412b5a78bc1e4a632da371f886a6144c67',
                   'robots.robot': '7e8c08f41f34817146d076891747ac7a2e0258a1a86ea6a985ede0baaec87d4a',
                   'robots.trial': '9a6df23ba2c1a211836918b061e60757a5df19bc4478eacdf0f128a56179f5a5',
                   'robots.trips': '6cbe5afb70b743890a107883d9abbc19e83be1050844c4527e3ec4f8936a88a7',
                   'robots.visits': 'd646305b3a05c6f5d5147d4c51a0a5fd15add3c577005af6f6828d1b44c4422a',
                   'summary.generated': '49715590a5b7ba2f093ad2307cb89ece44d624a5a27c2d3f7e3d838ea5135384',
                   'summary.items_per_trip': 'fded570a25284cbe46cbca90fd890044527c6ef0c4369b1c8d906b7fe7904d29',
                   'summary.picked': '5560a232c5763282d044063b6ef548caf5dc96510a9c120bbed09911339ec2d5',
                   'summary.rate': 'a00203a88dacce9cff26a57e230d182bcf21158357f8e9b1d80fd9c4a06a5d68',
                   'summary.seed': 'bd00ef1c87db2cc1d54852586f600c10d62e9d4ca1887196ce2d0eecd91082f6',
                   'summary.served': '70ca4b288436d22787f164454bba8433f71b5606a5bec679e565ac109509558d',
                   'summary.trial': 'e2e2033ae7e19d680599d4eb0a1359a2b48ec5baac75066c317fbf85159c54ef',
                   'summary.trips': '9ed154cb8fa7694195f96a690912e3bfc108e81de3eea43c639f7324fe67e7c8',
                   'summary.visits': '98f4720cddebbc347891ab520f01e5668c9df648b84b738d355a07f79fcec603'},
 'fp_poisson_r_private': {'robots.items': 'f37452e5d8d2a7a4750523d853fd9deb1cd591fd88ed8914521642f372979759',
                          'robots.robot': '7e8c08f41f34817146d076891747ac7a2e0258a1a86ea6a985ede0baaec87d4a',
                          'robots.trial': '9a6df23ba2c1a211836918b061e60757a5df19bc4478eacdf0f128a56179f5a5',
                          'robots.trips': '7ec55baaa3cef8465d921fbc1457c80c32ddee8ea7de2ef7da810799e38c39de',
                          'robots.visits': '5dfc4a5d1c3b4c62a1451b713427cf78b40a3c3c315017a98700f9ef26bd0a2b',
                          'summary.generated': '49715590a5b7ba2f093ad2307cb89ece44d624a5a27c2d3f7e3d838ea5135384',
                          'summary.items_per_trip': '473c1b6c30913e2d9db898fa1f2c72552267e39992403f6cc9f4528fef38a5b0',
                          'summary.picked': '1280cf75a3f30829b75ffb83232ded1b48204bbf7eef9b278f81605ffc22ad52',
                          'summary.rate': 'db5b7f621600824f87ea01e27ced1bc4a24d0ce23f7c5da98245aa951ebe4725',
                          'summary.seed': 'bd00ef1c87db2cc1d54852586f600c10d62e9d4ca1887196ce2d0eecd91082f6',
                          'summary.served': '9a2cdaaceef1f3099a8b19cc60370178bf88380706edd80a5f6941930f8a15d9',
                          'summary.trial': 'e2e2033ae7e19d680599d4eb0a1359a2b48ec5baac75066c317fbf85159c54ef',
                          'summary.trips': 'df02db5260bf1d7d05fbae8d1753fe15404235e04925c9b81eac4786fdbfa6ae',
                          'summary.visits': 'c408a3a5a8f8b96a5b4a7c1570724d9e89996625a420b5e60cbe8cf55e9d931b'},
 'idp_gr_coarse': {'robots.items': 'bd5f6018182a90ada002e0e5137271f3a65b063a8f8315a9c20073ae245310fa',
                   'robots.robot': '946b433c813e5bc75abf170471022b2c0f4a477170043dbb41c4d0ee0147c42d',
                   'robots.trial': 'e7867e0edcbf0fc617ab4b18ddc5d8949d50e9086717dcfabe2232bae0febc96',
                   'robots.trips': '5b3170551dc39560f97aaae51ce73628ba7ddb985d95de89b7369aefc96bbcfd',
                   'robots.visits': '8a3620bbb405e4f03e000e349450141a5495191c5a68e55282857cb44a6368ff',
                   'summary.generated': '1cc31345a599a132398ad8518bde469e5463641f2da9250c0ac6b2b0923c2e3a',
                   'summary.items_per_trip': '8ceddf13c1c8f778408cc4f34e326d7608c3aa7c3187993a55f417a26b6191d6',
                   'summary.picked': '0144812558c73d6260584a6185ec30f1220d3ff237e1e81c7fbc8bfe6b618ae6',
                   'summary.rate': '98d53b6c05c720dcb46ed67bac5783f5050664391839d1f5aeae4500abcebf7f',
                   'summary.seed': '9e6ed801146fe33aa91bb80ed0e1f0700e6068af7e44f54236ca65254358d530',
                   'summary.served': '0144812558c73d6260584a6185ec30f1220d3ff237e1e81c7fbc8bfe6b618ae6',
                   'summary.trial': '0c730b69905c5ef7a4ca5269f72365400bde2dd2c04eaf9bbb3d1c4a265a0131',
                   'summary.trips': 'a3d1205fd5a26348aaccca2d61fca6adec9d24d87afd6b0255b29c60fdf6c44f',
                   'summary.visits': '8589ef33c04a9dbb9c8dfd103ca11f64634749690bfa34cee8e5f905756b5183'},
 'idp_gric_mu': {'robots.items': '67b3bd39584227068b93f21518a8a24e4dab6c762fe26a4803d98d3982989479',
                 'robots.robot': 'd1e6d8ebc4167fbcddc79dd754d1051e7234787b1b25fe7e626149c4c4ee7157',
                 'robots.trial': '6abf1be42ea5861ad4d059dd875820054f424b3e15cf48ea80b66e3142eda622',
                 'robots.trips': '64d4c61cf1976530e08b3646d4e3e14b87750edc67695365ca1ed99192666d09',
                 'robots.visits': 'f706eb3ada820c4f2da89c27cf39bcb379ed13b1ee390c5ed6b532a1675d7f9c',
                 'summary.generated': '7a82ecd904141c947b09e1a3c286ed5f9df5788629ef81797f0cb9452fb0b63d',
                 'summary.items_per_trip': 'afec5660a781623d06bfc8a3ece7b95a26fb09b7458270efe32858d084558aff',
                 'summary.picked': '17e40ac9f734274226a19bee2d562177b2015ec4f87deb4b6df1bfd436cd794f',
                 'summary.rate': '30b9d99bb2790f97c9102269aec4b9ce69097fd0f12844ccc5f4191310a142bf',
                 'summary.seed': '9e6ed801146fe33aa91bb80ed0e1f0700e6068af7e44f54236ca65254358d530',
                 'summary.served': '17e40ac9f734274226a19bee2d562177b2015ec4f87deb4b6df1bfd436cd794f',
                 'summary.trial': '0c730b69905c5ef7a4ca5269f72365400bde2dd2c04eaf9bbb3d1c4a265a0131',
                 'summary.trips': 'b46daaacc3be6c9ea38a748caf9cac2ee5b3294dc8aa22cc2eb800d9ada6dbd7',
                 'summary.visits': 'e1791dd0cd9728099c209745cc0110d3267c5f6afe29cc70b7095ea539cb5fca'}}


def digests(params):
    tables = simulate(params)
    return {f"{table}.{name}": hashlib.sha256(np.ascontiguousarray(values).astype(values.dtype.newbyteorder("<"))
                                              .tobytes()).hexdigest()
            for table, columns in tables.items() for name, values in columns.items()}


@pytest.mark.parametrize("name", sorted(RUNS))
def test_fingerprint(name):
    assert digests(RUNS[name]) == EXPECTED[name]
