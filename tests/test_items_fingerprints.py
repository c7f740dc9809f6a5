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

EXPECTED = {'fp_bernoulli_cas_rate': {'robots.items': '126f1ee9653e20cba54b4dc398cf4163431e84b753d17e222a3138a6570a699d',
                           'robots.robot': '454dd723f251a585f455c1c674acef15a3ce9ffa615555648d1dc83a45d5a0a5',
                           'robots.trial': 'b45bdf057d4d314c437b61294b490681bcdf435eddf1512b2de952b9d5cad5c4',
                           'robots.trips': '5a4821c16204b01c61dda447b453d0c7da49bd470a50e72439a678d7ac7d4d6c',
                           'robots.visits': '6e88980188e0dd405f8532cd852bec36d2a3e46eca936a4b40276319d4a8f4f4',
                           'summary.generated': '34c0150d667707df35b4dab149897980713e23ca42b12a49aef1687b6e399e4a',
                           'summary.items_per_trip': 'b41c0225c3e96e18e870c81c42a8e9af6d4a01a6be55dc780639fc5a92ee069f',
                           'summary.picked': '2d6dff1ebb92a35ddd1a930a542a7bbd5f799c4d43c947e09178cef26f7b9c02',
                           'summary.rate': '6592797f1f84993060c6ffe324759b76b8bcb2718a2c810d7226939817db069c',
                           'summary.seed': 'bd00ef1c87db2cc1d54852586f600c10d62e9d4ca1887196ce2d0eecd91082f6',
                           'summary.served': '34b888b1657802a46c949f02dd6cd4823ac84ef02ab5935bc86105c87f042307',
                           'summary.trial': 'e2e2033ae7e19d680599d4eb0a1359a2b48ec5baac75066c317fbf85159c54ef',
                           'summary.trips': '28b10d0668d6e781b26d12371111ee4535f859cac7e0f182e521bb341ce7b24b',
                           'summary.visits': 'c1e34f0d674fca445cb84c5bf36e6eb19cb74e02f758fb0d87fd647c7f909bf2'},
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
 'fp_poisson_gr': {'robots.items': '07cc0c98b323084caf6d242e6113e7128a2049bd47133cf2a556b200155dd597',
                   'robots.robot': '7e8c08f41f34817146d076891747ac7a2e0258a1a86ea6a985ede0baaec87d4a',
                   'robots.trial': '9a6df23ba2c1a211836918b061e60757a5df19bc4478eacdf0f128a56179f5a5',
                   'robots.trips': 'a191a607766ba7254f9276af6755ad496aa382e65812cbed678199c31dfe1da6',
                   'robots.visits': '5e82792412b444493370b1b8e2367902c989793d42f8da73b07c39522fd225eb',
                   'summary.generated': '49715590a5b7ba2f093ad2307cb89ece44d624a5a27c2d3f7e3d838ea5135384',
                   'summary.items_per_trip': '3139a128d550220cbd20c5459968c70b2b617d6d05add231019584dd4b0130eb',
                   'summary.picked': '6b3bec8bd3d17580d0d1ceb6a2836c455b24c0d5f1f39794790ff749e1abe09d',
                   'summary.rate': '7c17f1abe602e163cedf66e2a3ecb20ef3679ace5b47600cfc86a8eff995138d',
                   'summary.seed': 'bd00ef1c87db2cc1d54852586f600c10d62e9d4ca1887196ce2d0eecd91082f6',
                   'summary.served': 'f343c5b80a50d8d266e9b07b586ad1e5a06826b4079c95fb1226fa5a43e8a1a6',
                   'summary.trial': 'e2e2033ae7e19d680599d4eb0a1359a2b48ec5baac75066c317fbf85159c54ef',
                   'summary.trips': 'dc44a1b012e0f8d26007d1b3c58dd7239e549b6b24d1cb5a77f368f2ebc38934',
                   'summary.visits': 'f231f5179c6e81af2501ba0f7d043edd12433283a40ca5060f902112cc84065a'},
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
 'idp_gr_coarse': {'robots.items': 'fb7d179551aa147902222138fa46bb13116136ddd60553e13fb14bd20b6f73fb',
                   'robots.robot': '946b433c813e5bc75abf170471022b2c0f4a477170043dbb41c4d0ee0147c42d',
                   'robots.trial': 'e7867e0edcbf0fc617ab4b18ddc5d8949d50e9086717dcfabe2232bae0febc96',
                   'robots.trips': 'b83b8ae67ec2126823d4cc26954e123fa3f8f5257b25823c68d4ad33f9f016ca',
                   'robots.visits': '54e6765ffc2afeed788ec564669edaf0b9e4b1ebdb33247c8eff82f4f769195c',
                   'summary.generated': '1cc31345a599a132398ad8518bde469e5463641f2da9250c0ac6b2b0923c2e3a',
                   'summary.items_per_trip': '3ebb0c41c9eecc919fbe5b73a3fa29a40c56101975567c731f7040a80ce9b201',
                   'summary.picked': 'd642fc8afcd08f23a11ca7390da26d1ae0bc242021fe1aa01ef0a12bd1c7a081',
                   'summary.rate': 'b8a425bdfd434e3cf78df2213f2ac7a017548a927dd422e55338121ffcf88c6d',
                   'summary.seed': '9e6ed801146fe33aa91bb80ed0e1f0700e6068af7e44f54236ca65254358d530',
                   'summary.served': 'd642fc8afcd08f23a11ca7390da26d1ae0bc242021fe1aa01ef0a12bd1c7a081',
                   'summary.trial': '0c730b69905c5ef7a4ca5269f72365400bde2dd2c04eaf9bbb3d1c4a265a0131',
                   'summary.trips': '982f3339bb4f7e9669fdd797e484d93ec2d7a276f259fbbbefcd153a7cf59778',
                   'summary.visits': '573a045745f7d5b228e39a0fc0f5122571647bcdd1a3d0bdcd5d8d523d686114'},
 'idp_gric_mu': {'robots.items': 'b4253675a9a53cd798173115a6fe7f6d947521ab8dad3cefe137e39f385d7a77',
                 'robots.robot': 'd1e6d8ebc4167fbcddc79dd754d1051e7234787b1b25fe7e626149c4c4ee7157',
                 'robots.trial': '6abf1be42ea5861ad4d059dd875820054f424b3e15cf48ea80b66e3142eda622',
                 'robots.trips': '1d78f44b34ba2171561d2a0eb96a8e3f6da09b5a3f5376fc549a0e2390be2ace',
                 'robots.visits': 'bfd3ee582c75983765285a1857fbf8fab52ea2d1ea83e6199a35e49e48a5330c',
                 'summary.generated': '7a82ecd904141c947b09e1a3c286ed5f9df5788629ef81797f0cb9452fb0b63d',
                 'summary.items_per_trip': 'ac363e074c154316c8d0bbf984128cbc1222f6f756dff0f4bde1d24ea7a73b3a',
                 'summary.picked': '23315edba85d9dd5da20ab38efa0d0062dfcadc08fdee28622963f3eef4bb494',
                 'summary.rate': 'c8399dd2ea0bbc2548e7fe9a66c344ea6f2bf47e3b994c3f2627931424621a11',
                 'summary.seed': '9e6ed801146fe33aa91bb80ed0e1f0700e6068af7e44f54236ca65254358d530',
                 'summary.served': '23315edba85d9dd5da20ab38efa0d0062dfcadc08fdee28622963f3eef4bb494',
                 'summary.trial': '0c730b69905c5ef7a4ca5269f72365400bde2dd2c04eaf9bbb3d1c4a265a0131',
                 'summary.trips': 'e932a9e2960094b27c6538af3a4c459ed5b7bd61e33d200d9472c4d4818e64d8',
                 'summary.visits': '68a2ba67258ebc7e07c14ec6ab44e89ec812e852f669fed9308fe57a021abe47'}}


def digests(params):
    tables = simulate(params)
    return {f"{table}.{name}": hashlib.sha256(np.ascontiguousarray(values).astype(values.dtype.newbyteorder("<"))
                                              .tobytes()).hexdigest()
            for table, columns in tables.items() for name, values in columns.items()}


@pytest.mark.parametrize("name", sorted(RUNS))
def test_fingerprint(name):
    assert digests(RUNS[name]) == EXPECTED[name]
