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

EXPECTED = {'fp_bernoulli_cas_rate': {'robots.items': 'd0acc0174ea2ebe77823d9bdc0a9d4b388a354d5999d67706d2fb419696222bf',
                           'robots.robot': '454dd723f251a585f455c1c674acef15a3ce9ffa615555648d1dc83a45d5a0a5',
                           'robots.trial': 'b45bdf057d4d314c437b61294b490681bcdf435eddf1512b2de952b9d5cad5c4',
                           'robots.trips': '2ecec8e2b0a1a8254015e7af03581085eeb1fffcabbb2341f558d009c3da8a03',
                           'robots.visits': '084ed74b69cc0d2265b41bf081765926316e006d327d66c218c1a5e8bc07ca31',
                           'summary.generated': '597dce29bb2c4ccab0146c04e82dd780d21f42479b42f73abc970cbb871917f3',
                           'summary.items_per_trip': 'b41c0225c3e96e18e870c81c42a8e9af6d4a01a6be55dc780639fc5a92ee069f',
                           'summary.picked': 'ef3c67de2a6dbf50831747702e161e3ecd4287810266751656a010a2c5ebf003',
                           'summary.rate': '7b5bb29d01bb330782144b4e05f317ea8e0e07cf15029bb37bdb79650412bb14',
                           'summary.seed': 'bd00ef1c87db2cc1d54852586f600c10d62e9d4ca1887196ce2d0eecd91082f6',
                           'summary.served': '644ff156d7bef328322bb861d6a7529d96513994641a40b626b5cb291ccb6724',
                           'summary.trial': 'e2e2033ae7e19d680599d4eb0a1359a2b48ec5baac75066c317fbf85159c54ef',
                           'summary.trips': '2e7d8dc51170f4855fb0f8f8dc72b9192e6d891d7ed76efd129b2926d9e434f5',
                           'summary.visits': '03eabf621be8d2b011f1455cd09a6ab7688f6a8d45fa093ddac97d98f1fffc49'},
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
 'fp_poisson_gr': {'robots.items': 'b68ea97b5f99523dabc4ee37e8749f106be2cd98e87996c784660293ceb9d62b',
                   'robots.robot': '7e8c08f41f34817146d076891747ac7a2e0258a1a86ea6a985ede0baaec87d4a',
                   'robots.trial': '9a6df23ba2c1a211836918b061e60757a5df19bc4478eacdf0f128a56179f5a5',
                   'robots.trips': 'b50d8a057b805f49c9f7ef9cfa541d3221f4c31e6204f77a7195d040192fbc23',
                   'robots.visits': '5b882d506161cd9e79f218adc69923e0492a3b4714e82d45dd8e08f05e140aa7',
                   'summary.generated': 'af0d548c71d79d08b656df044ba7abc9b8802f342add4f34d450b21b14a01344',
                   'summary.items_per_trip': '34c8300056a40c329544686fc76e160c2420084b2eda4602afe5687478a9393a',
                   'summary.picked': '5f1864dc2d774b54ec583c083ff5f868baf6ce93f51d54385f5dd0f1639be228',
                   'summary.rate': '75a8cf4085ef300bc6cfa4c65af37ed2ee08a8cb01012ce94ff099c096c886ac',
                   'summary.seed': 'bd00ef1c87db2cc1d54852586f600c10d62e9d4ca1887196ce2d0eecd91082f6',
                   'summary.served': '5cd9eb58dfb34d917d12fef0b9231ef190f929e75cd05299557773627f5d6547',
                   'summary.trial': 'e2e2033ae7e19d680599d4eb0a1359a2b48ec5baac75066c317fbf85159c54ef',
                   'summary.trips': '336131e46fd20470f837c669fe88a02d5c0c25f81b6b26ec52da78b8af5fd50a',
                   'summary.visits': '0665fe0fb113551e5a04b38c46831aeaec4c9fe1f44acd1b67eb61d46cd5c0f7'},
 'fp_poisson_r_private': {'robots.items': '896249f5f407739f47ba0157e3cfb15ff8eb4b068f0e763653c3ccbe56f7dcaf',
                          'robots.robot': '7e8c08f41f34817146d076891747ac7a2e0258a1a86ea6a985ede0baaec87d4a',
                          'robots.trial': '9a6df23ba2c1a211836918b061e60757a5df19bc4478eacdf0f128a56179f5a5',
                          'robots.trips': '0e21a87b994dd0bc67affedf11ec4d2f369c3e1065d3e1ffb83ec3c53bf1202c',
                          'robots.visits': '084433052565aaa412b81baa30aaa358de1f3ebb780374849f1a0fa08183c9cc',
                          'summary.generated': 'af0d548c71d79d08b656df044ba7abc9b8802f342add4f34d450b21b14a01344',
                          'summary.items_per_trip': 'ca1c73f55b8171561e3c144cf936f5131e0c3f56ed527f15e2004aca49d346f7',
                          'summary.picked': '0cae27b0639995f026788a6b18e1b91ffb2041c1cef99dc498b3456ebbca1be2',
                          'summary.rate': 'aad7637b7b0b7d87f08fb5bad93c2ced6aadf564d677d2230bace0217c55c5cc',
                          'summary.seed': 'bd00ef1c87db2cc1d54852586f600c10d62e9d4ca1887196ce2d0eecd91082f6',
                          'summary.served': '0cbe28f5d3d8ce0aefee2095a778bcee6415dafa731e52e3c5b0d9b2dd06e1c8',
                          'summary.trial': 'e2e2033ae7e19d680599d4eb0a1359a2b48ec5baac75066c317fbf85159c54ef',
                          'summary.trips': '932f29cf7d81d4a27faac3ee91cefaeafffd405f2d7a46f2739c2b865356053f',
                          'summary.visits': '10f55649cdd6d8514d57930fdc43b793cad3211025c3c059b2977652a920a30b'},
 'idp_gr_coarse': {'robots.items': '2cc1b685156fad87c1be00ccaea54ec2e7a1425990c456729252f2b17181e3c5',
                   'robots.robot': '946b433c813e5bc75abf170471022b2c0f4a477170043dbb41c4d0ee0147c42d',
                   'robots.trial': 'e7867e0edcbf0fc617ab4b18ddc5d8949d50e9086717dcfabe2232bae0febc96',
                   'robots.trips': 'b7a66f33dc6df3ef7431aeed61811675a18575eb1bb6998bde272743fef0bfd3',
                   'robots.visits': 'c74f6323bd4c9e67d5d00b777247468dc097fab9c1e141d7f68db222817df3ad',
                   'summary.generated': '68ee6b1103c6d724c68c83c44a91bec1bf4c1c01f39d0d4898b387900b364d10',
                   'summary.items_per_trip': '1b9b04ca7e24a1b6a07c5d69c8d449a0bc4a2c197579b427017558efba8bc9a0',
                   'summary.picked': '6b4ccec6600ac99b57990acfb894f44542398b1b47bf70a714f26f79cbde6dfe',
                   'summary.rate': 'd2ae860813619f6382970178637a3121dd10729eac86fd22a6fc60a83b73b8a7',
                   'summary.seed': '9e6ed801146fe33aa91bb80ed0e1f0700e6068af7e44f54236ca65254358d530',
                   'summary.served': '6b4ccec6600ac99b57990acfb894f44542398b1b47bf70a714f26f79cbde6dfe',
                   'summary.trial': '0c730b69905c5ef7a4ca5269f72365400bde2dd2c04eaf9bbb3d1c4a265a0131',
                   'summary.trips': '45751f2ff3188dcc6b998c6d4cd1a07398e48b3592dbc848a1d2c8b97bc04b30',
                   'summary.visits': '8bce55907a7b2e8f6527f3adbea7f54156ce1d81ec92e31da0aca10f29a5933a'},
 'idp_gric_mu': {'robots.items': '353d3f9463e34d91f54855661a7f963ee645cb75d4a82166f58e2e18f46e83c4',
                 'robots.robot': 'd1e6d8ebc4167fbcddc79dd754d1051e7234787b1b25fe7e626149c4c4ee7157',
                 'robots.trial': '6abf1be42ea5861ad4d059dd875820054f424b3e15cf48ea80b66e3142eda622',
                 'robots.trips': '2cf0b14cf7223ac8f2e21bac971b844ba6bb53a973fcfd18a116c7bc28127100',
                 'robots.visits': 'e5c4611058ebbde7c35519f2bf88ca7c17a7ee918f52dd45606af864e2b50b6a',
                 'summary.generated': '5305e4ff844b1385323859e61de089f11b6e8a7296bd34267399f31a2ccdfa7c',
                 'summary.items_per_trip': 'da560efde3a03363ba601958bba62604dfea6988332436886da04c192b40ead1',
                 'summary.picked': 'f3111fca582df029c7242de9de90decfe9e9ce030d08dca33f1fd730a83d1f08',
                 'summary.rate': 'b64dfb7aae8329fa789762958d75cd5bab508a885bc7de05b948a406e91970ed',
                 'summary.seed': '9e6ed801146fe33aa91bb80ed0e1f0700e6068af7e44f54236ca65254358d530',
                 'summary.served': 'f3111fca582df029c7242de9de90decfe9e9ce030d08dca33f1fd730a83d1f08',
                 'summary.trial': '0c730b69905c5ef7a4ca5269f72365400bde2dd2c04eaf9bbb3d1c4a265a0131',
                 'summary.trips': '2961720478b197b299ddc8392c5095424126bd5320f81b06b25d50194ffbd60c',
                 'summary.visits': 'b9061ba6c60a142bca7cf6798f6174eb933939c4448a161190ba4f3cdd473f0d'}}


def digests(params):
    tables = simulate(params)
    return {f"{table}.{name}": hashlib.sha256(np.ascontiguousarray(values).astype(values.dtype.newbyteorder("<"))
                                              .tobytes()).hexdigest()
            for table, columns in tables.items() for name, values in columns.items()}


@pytest.mark.parametrize("name", sorted(RUNS))
def test_fingerprint(name):
    assert digests(RUNS[name]) == EXPECTED[name]
