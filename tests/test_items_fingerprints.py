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

EXPECTED = {'fp_bernoulli_cas_rate': {'robots.items': '3a0faa97c77fef25655da230f8b43a5abcddc9ab4851929966a1deb94b06d7a9',
                           'robots.robot': '454dd723f251a585f455c1c674acef15a3ce9ffa615555648d1dc83a45d5a0a5',
                           'robots.trial': 'b45bdf057d4d314c437b61294b490681bcdf435eddf1512b2de952b9d5cad5c4',
                           'robots.trips': '3569e70183f6ca7d76f2f925391be1ca8d8da2eecb8a2f27a1203e00bad11924',
                           'robots.visits': 'a5a792516d9dac7f43e2dbbc1578a2d9f551fa20834fc2a485a245e832d3f608',
                           'summary.generated': '34c0150d667707df35b4dab149897980713e23ca42b12a49aef1687b6e399e4a',
                           'summary.items_per_trip': 'b41c0225c3e96e18e870c81c42a8e9af6d4a01a6be55dc780639fc5a92ee069f',
                           'summary.picked': '540f4c8e70ca24f518a3a1df9b1257ab1e6ead7bb98abce55ff074f653afada1',
                           'summary.rate': 'ee5e1f1c6157dc2e263b93d42a18f481db857734c949d491df043cad93eeb107',
                           'summary.seed': 'bd00ef1c87db2cc1d54852586f600c10d62e9d4ca1887196ce2d0eecd91082f6',
                           'summary.served': '6104a913b43d90e3bcbc56ce06bc5a3f296a59ef4176beac3c3509520d163b20',
                           'summary.trial': 'e2e2033ae7e19d680599d4eb0a1359a2b48ec5baac75066c317fbf85159c54ef',
                           'summary.trips': '29992d6acc316e60ad951daaa58640870d433af6cb06fdf1518fbb4adb79e7aa',
                           'summary.visits': '0a5c5219cecfb65c3dd15c349c5ccf0d89d63a1a0ef31adc94e6244b815e4536'},
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
 'fp_poisson_gr': {'robots.items': '9b19f630fbb01c644f1fc2abaee6c841a7f83b585a8b4a76cfeebe302e8f83ba',
                   'robots.robot': '7e8c08f41f34817146d076891747ac7a2e0258a1a86ea6a985ede0baaec87d4a',
                   'robots.trial': '9a6df23ba2c1a211836918b061e60757a5df19bc4478eacdf0f128a56179f5a5',
                   'robots.trips': '698c509c4fc9a68d9b922950c23a92fef5e57b7dabac0559ebad4d006f64e7ff',
                   'robots.visits': 'f1b8a000501f6383bf70c5dc4898e7075d5f1aa4a63a8dca0d4b35e6ed9bafef',
                   'summary.generated': '49715590a5b7ba2f093ad2307cb89ece44d624a5a27c2d3f7e3d838ea5135384',
                   'summary.items_per_trip': '20a91f7bae008a0532d2e9efca791b857fce2b6727054d495eb040cc468240d4',
                   'summary.picked': 'ca4d310f4508429d495cc4a4f56555de0aaf089c52583acbf4f4943536fe0714',
                   'summary.rate': '1a46ab4cb3eaa9b80e895b9a903c06df2dc7510cc6b32272bcaaddfb44f6ff2b',
                   'summary.seed': 'bd00ef1c87db2cc1d54852586f600c10d62e9d4ca1887196ce2d0eecd91082f6',
                   'summary.served': '9382f4a8082469ca13ab61910130d122e624ccd88cfb963c469ce368b75ff3c3',
                   'summary.trial': 'e2e2033ae7e19d680599d4eb0a1359a2b48ec5baac75066c317fbf85159c54ef',
                   'summary.trips': '641ac3c6e8f1754ae18a2af8674f3f08ad71f0fcd06620d555a67a122c7a9906',
                   'summary.visits': '8d80d6dc378fba2206c2f51ed62cb4f6a55863d850b33db20de295101be9a5dc'},
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
 'idp_gr_coarse': {'robots.items': '7a2425ac43678864196c0e392612b8e223606678c5fc24295705bf27c7b077ab',
                   'robots.robot': '946b433c813e5bc75abf170471022b2c0f4a477170043dbb41c4d0ee0147c42d',
                   'robots.trial': 'e7867e0edcbf0fc617ab4b18ddc5d8949d50e9086717dcfabe2232bae0febc96',
                   'robots.trips': 'a787cbb6d7bab6d44b7a232961ef8e4345b1b2a8f944eed321110bd23395a340',
                   'robots.visits': 'e19a429a08fdafb17398dc510e31d4e325e91adc26945c8a52619fae716ff79c',
                   'summary.generated': '1cc31345a599a132398ad8518bde469e5463641f2da9250c0ac6b2b0923c2e3a',
                   'summary.items_per_trip': 'fce9548a4f332744d6323aa774885a412f253e183abc5a7251167f0f6400f8ba',
                   'summary.picked': 'f63fcd56f6ecb55095f53e2e8ba914d6f0de1364d6efe1e227d894beb1eb9f5e',
                   'summary.rate': '84507ba1924ff8949ceb9038d6753d27090a6b6938b3522442c61f05cf73d55d',
                   'summary.seed': '9e6ed801146fe33aa91bb80ed0e1f0700e6068af7e44f54236ca65254358d530',
                   'summary.served': 'f63fcd56f6ecb55095f53e2e8ba914d6f0de1364d6efe1e227d894beb1eb9f5e',
                   'summary.trial': '0c730b69905c5ef7a4ca5269f72365400bde2dd2c04eaf9bbb3d1c4a265a0131',
                   'summary.trips': '158a999558c1eeb0cf8305031b2170925008c75b3a8a987863ca2206dfa5181e',
                   'summary.visits': 'dc323970c8a936b6288d11b232b9b6d57ba69089d95ab94a49392e8d1d06e23a'},
 'idp_gric_mu': {'robots.items': '111d53290c93cd138fc24846918aa967e8d1c9e7722a9bd4674ad9fa99d882f7',
                 'robots.robot': 'd1e6d8ebc4167fbcddc79dd754d1051e7234787b1b25fe7e626149c4c4ee7157',
                 'robots.trial': '6abf1be42ea5861ad4d059dd875820054f424b3e15cf48ea80b66e3142eda622',
                 'robots.trips': 'e4c81804d36de6c8fbc9420c0d6730adc2d4d3e5a085ef1fe2496d11d139d1af',
                 'robots.visits': '4da0f1035e8adaf8765f02071a0c7e66e3c71da6c98565b3aa5821bdc7b5af61',
                 'summary.generated': '7a82ecd904141c947b09e1a3c286ed5f9df5788629ef81797f0cb9452fb0b63d',
                 'summary.items_per_trip': 'ad1d916f4a275ba63873bab21f9a2cde1bffc221c9194564e2b217b16a5e4305',
                 'summary.picked': '3dc3850fa23e2615fc53d78588a0f2658a81e52dd329ed7bae23dbde4e0b6fb4',
                 'summary.rate': '7cb956d47930c6b31dda81b22a0e285b133e13c34e30af7a257af318c8047fbc',
                 'summary.seed': '9e6ed801146fe33aa91bb80ed0e1f0700e6068af7e44f54236ca65254358d530',
                 'summary.served': '3dc3850fa23e2615fc53d78588a0f2658a81e52dd329ed7bae23dbde4e0b6fb4',
                 'summary.trial': '0c730b69905c5ef7a4ca5269f72365400bde2dd2c04eaf9bbb3d1c4a265a0131',
                 'summary.trips': '0a29ee3682a5d124bfddbda79d14aeb3728080f4a11a2e057457984e28cd499b',
                 'summary.visits': '052cdc27c3b9c40baefb009c8acb3318d52e20c2b2bb1ca6411ad6e9fdadd676'}}


def digests(params):
    tables = simulate(params)
    return {f"{table}.{name}": hashlib.sha256(np.ascontiguousarray(values).astype(values.dtype.newbyteorder("<"))
                                              .tobytes()).hexdigest()
            for table, columns in tables.items() for name, values in columns.items()}


@pytest.mark.parametrize("name", sorted(RUNS))
def test_fingerprint(name):
    assert digests(RUNS[name]) == EXPECTED[name]
