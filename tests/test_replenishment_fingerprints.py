"""Golden fingerprints of the replenishment model: the same bytes from the same config and seeds.

Short runs (4 trials x 1500 ticks) of the fixed strategy and of 6 mobile
chargers (phi = 2), plus a run where transfers lose half their energy; each
per-trial summary column and the time series must give exactly these SHA-256
digests (of the little-endian array bytes). They were taken before the
kernel's speed-ups of issue 11, which left every output bit unchanged; any
later speed-up must keep them too. An intentional change of the model's
numbers regenerates them with :func:`digests` and pastes the dict here.
"""

import hashlib

import numpy as np
import pytest

from dronefleet.replenishment import Params, simulate
from dronefleet.replenishment.simulate import summary_columns

RUNS = {
    "fixed": Params(strategy="fixed", n_workers=6, ticks=1500, trials=4),
    "mobile": Params(strategy="mobile", n_workers=6, n_chargers=6, charger_capacity_factor=2.0,
                     ticks=1500, trials=4),
    "mobile_lossy": Params(strategy="mobile", n_workers=6, n_chargers=1,
                           charger_capacity_factor=1.0, work_ratio=4.0, charge_rate=0.25,
                           transfer_loss=0.5, ticks=1500, trials=4),
    # full-length runs (one trial's ticks end to end: reused steps, depletion, crowding);
    # digests from the kernel as of commit ae5b04d, before the speed-ups that followed it
    "fixed_long": Params(strategy="fixed", n_workers=6, ticks=6000, trials=3),
    "mobile_crowded_long": Params(strategy="mobile", n_workers=6, n_chargers=12,
                                  charger_capacity_factor=1.0, ticks=6000, trials=3),
    "mobile_few_long": Params(strategy="mobile", n_workers=6, n_chargers=2,
                              charger_capacity_factor=1.0, ticks=6000, trials=3),
}
ARRAYS = summary_columns() + ("battery", "given", "received", "series")

EXPECTED = {
    "fixed": {
        "battery": "5c5136588c612cf8091e5150bebc3d61a94d8d216fb3626a5577bf89bee1b6b7",
        "depleted_chargers": "66687aadf862bd776c8fc18b8e9f8e20089714856ee233b3902a591d0d5f2925",
        "depleted_workers": "66687aadf862bd776c8fc18b8e9f8e20089714856ee233b3902a591d0d5f2925",
        "efficiency": "a4652159bb09e9fa502cccc8960d269f18686b0297bfd25a70b1d058f85897a5",
        "efficiency_with_loss": "a4652159bb09e9fa502cccc8960d269f18686b0297bfd25a70b1d058f85897a5",
        "energy": "2f28b72d2a0062adb06023fdaf956a9d1171c448d56d371321edd0bdf8bce1d3",
        "given": "5d89f056865052bcb89c910d2d62872e029fb273c3db03f8968a52a41593c1b5",
        "lost": "66687aadf862bd776c8fc18b8e9f8e20089714856ee233b3902a591d0d5f2925",
        "received": "5d89f056865052bcb89c910d2d62872e029fb273c3db03f8968a52a41593c1b5",
        "seed": "f3dfca24d92ea77bd4695d1ba858969cc891c8bfb3977770a78d0fa644d5ff6b",
        "series": "21927e71f5de58ee77663ad6b9cb4ee723ab866123d334bed14e234e194d84ab",
        "shared": "66687aadf862bd776c8fc18b8e9f8e20089714856ee233b3902a591d0d5f2925",
        "trial": "73e200e2b048c86d4e8c86b86bf62bbda84c7384e34e250b01aa30ab29d234a4",
        "work": "983080e632314d6aecf3f80b51dde0600ae127d3e5a8167b000edd6d70ebab21",
        "work_energy": "ea69570695493289267d15ebc22dcd5601e222b6831920001fd4daf4069ed280",
    },
    "mobile": {
        "battery": "72a768cbd243dd0637e85ad4c29db5e5bc21c1c77baa11c9a22aa90c585ec33b",
        "depleted_chargers": "66687aadf862bd776c8fc18b8e9f8e20089714856ee233b3902a591d0d5f2925",
        "depleted_workers": "66687aadf862bd776c8fc18b8e9f8e20089714856ee233b3902a591d0d5f2925",
        "efficiency": "68eca3491c570823f8f9a767660120b9c5d91dc6506675e8017fae76d3fbcbbe",
        "efficiency_with_loss": "68eca3491c570823f8f9a767660120b9c5d91dc6506675e8017fae76d3fbcbbe",
        "energy": "f0e32229a472f5e403fb407f300c3350c23f91a8fb234b1dff6330b7dc973806",
        "given": "cd8b1e193adad4cf4bcc21b1ff4bf9ea19023710792e2d55e95fc7d6a823e92c",
        "lost": "66687aadf862bd776c8fc18b8e9f8e20089714856ee233b3902a591d0d5f2925",
        "received": "4f229b3c61d2b17fd75dddae8adaac1bc6543dea72626b047479bc7c3ee4552d",
        "seed": "f3dfca24d92ea77bd4695d1ba858969cc891c8bfb3977770a78d0fa644d5ff6b",
        "series": "7375bff1e02ed701ae94d683f656937942cb01dd469e7770b6f4968ed163b9c0",
        "shared": "b84383635ba56760bf7640e97012505ef73facafe9efcc2e119426e8b40f4ec1",
        "trial": "73e200e2b048c86d4e8c86b86bf62bbda84c7384e34e250b01aa30ab29d234a4",
        "work": "0d53b26a84688bce41c851646a34c5d7d89f82b2979f944389f77d97a55eb825",
        "work_energy": "9c9efcef545e30a117c7135bd839a97de2b65eb7a51fca560ee576d2276ce062",
    },
    "mobile_lossy": {
        "battery": "5d44ab883d8cafdcb83598d8a8d4d84147b49cb0df5ec91599bcddbb26629c38",
        "depleted_chargers": "66687aadf862bd776c8fc18b8e9f8e20089714856ee233b3902a591d0d5f2925",
        "depleted_workers": "91d3827f052f5a4b44d5fe2bed657c752247365d94f80a33cb09c1436a16b125",
        "efficiency": "9d9d4bec89c0e9d5dd094be66aa65fe7e2ade87033380a7b31bb9647e2103c76",
        "efficiency_with_loss": "f25285d02003f1e12ce7617db626df39886b621a66c1c0834cf9f3b0dac8f1c7",
        "energy": "c7d539acaa00786f37130bbb266a32464a9a5ef19b76281dd7a4f6c51f9fb986",
        "given": "708b224c9ab191b8ed0950d8df2f2e7efe620155cfdca8890961fd0b42677d5f",
        "lost": "a09d5de6ac655d5e3c5ea270dc2771ec995ee8cc2dbbeb74d204d2ad9d9a5e10",
        "received": "d3530196e6d759df244440f4eb19d436c0509be447d5ef0d8b7b1513884aefef",
        "seed": "f3dfca24d92ea77bd4695d1ba858969cc891c8bfb3977770a78d0fa644d5ff6b",
        "series": "8890b3efde7713a7783f8c9b93858817ca836fd3019546f48248ed856daad100",
        "shared": "a09d5de6ac655d5e3c5ea270dc2771ec995ee8cc2dbbeb74d204d2ad9d9a5e10",
        "trial": "73e200e2b048c86d4e8c86b86bf62bbda84c7384e34e250b01aa30ab29d234a4",
        "work": "7b12fab6d8c86b3b96c34031483f647a8ce38adfdc1b88db8181f37c412a6f39",
        "work_energy": "d55f8169cedd0fe82f3f6224d5c55d8470127fb261e22ef82191bd8fe91b77d0",
    },
    "fixed_long": {
        "battery": "c2997af0aef7e287b1413f54932117fe750917f00425eed8b1e2ebb3c1d3d656",
        "depleted_chargers": "9d908ecfb6b256def8b49a7c504e6c889c4b0e41fe6ce3e01863dd7b61a20aa0",
        "depleted_workers": "9d908ecfb6b256def8b49a7c504e6c889c4b0e41fe6ce3e01863dd7b61a20aa0",
        "efficiency": "db2b079c8560e45bbfb3a2a1ed3f2d2f80ce8fb6e7711ec23e3ff79b55ccb5e0",
        "efficiency_with_loss": "db2b079c8560e45bbfb3a2a1ed3f2d2f80ce8fb6e7711ec23e3ff79b55ccb5e0",
        "energy": "29853761d3c5a97ebe89c1c4e173813695e7eb925406ffe8e0f5f44b05fa519d",
        "given": "81c611f35bff79491538b2f7cf201c7597a661a5c549633541c62bdc8af1613f",
        "lost": "9d908ecfb6b256def8b49a7c504e6c889c4b0e41fe6ce3e01863dd7b61a20aa0",
        "received": "81c611f35bff79491538b2f7cf201c7597a661a5c549633541c62bdc8af1613f",
        "seed": "316524109059c7b4016aa2fceee5f44923d3eb9cc3b1414ec96aa41d395e9a29",
        "series": "8a8f8ddff3963ee4dc095e4122d9685b9837a6258f0c1e08974df1dcb8f9d6b5",
        "shared": "9d908ecfb6b256def8b49a7c504e6c889c4b0e41fe6ce3e01863dd7b61a20aa0",
        "trial": "e2e2033ae7e19d680599d4eb0a1359a2b48ec5baac75066c317fbf85159c54ef",
        "work": "75d0615a7f8af5f660194d1fd329d17b5a8faff23d52b5b11e44730fca2d522a",
        "work_energy": "d31e07fc8bcdd844c64a228dcc5c77ad1a83cfb241423a4d16ec83c2d31f1640",
    },
    "mobile_crowded_long": {
        "battery": "10c777392f6af5fd0cc0d65063f6b270e9dffe38ef8d598a98519c3485636c98",
        "depleted_chargers": "9d908ecfb6b256def8b49a7c504e6c889c4b0e41fe6ce3e01863dd7b61a20aa0",
        "depleted_workers": "9d908ecfb6b256def8b49a7c504e6c889c4b0e41fe6ce3e01863dd7b61a20aa0",
        "efficiency": "b5ce3283cd1029a72ab4ef11cd0691fd700f286d1c09a8d687e5aae18e686cd9",
        "efficiency_with_loss": "b5ce3283cd1029a72ab4ef11cd0691fd700f286d1c09a8d687e5aae18e686cd9",
        "energy": "83d0df74902bec15f25f2a7c99a93878435e4505c75d753d3dadc8cdbb6c8c1c",
        "given": "92fa807ff2c61f5540d5df7cd54e254ee92f3159e09a8c073697f479a374dfbb",
        "lost": "9d908ecfb6b256def8b49a7c504e6c889c4b0e41fe6ce3e01863dd7b61a20aa0",
        "received": "1f4111cae0be00c5b4af366f2f66d47363132e3a8c46107a0aafbeef9a0d5cfb",
        "seed": "316524109059c7b4016aa2fceee5f44923d3eb9cc3b1414ec96aa41d395e9a29",
        "series": "7097579bf072a0784c881b2ad8f6543bf48ca633bd7a5c4724209994ae23e18b",
        "shared": "2069b5d467ebff4ca2daab97eb015be825ab5c4250de0f0473acba2d197aa432",
        "trial": "e2e2033ae7e19d680599d4eb0a1359a2b48ec5baac75066c317fbf85159c54ef",
        "work": "1f863631c94a1811d170af404850759aa0e4e1b9b88c774a982b8cf2b5d8f1c7",
        "work_energy": "ac118a5ff61e27c7566e64083b8c73b9777f979e57aeade6e161ad1862ec2242",
    },
    "mobile_few_long": {
        "battery": "ebf6b30a05e6d9f1cb95535d2e665480439af13b8a5bc62f786029e048ddaf7c",
        "depleted_chargers": "9d908ecfb6b256def8b49a7c504e6c889c4b0e41fe6ce3e01863dd7b61a20aa0",
        "depleted_workers": "198950af48e0c178d1e80017a467e5322a76c6f1ebbe5a8e4860705ccc19ce6b",
        "efficiency": "ef2202b59276f55387fce758f2e54e27dc45c3553627371d4a2b62a8f2c86b23",
        "efficiency_with_loss": "ef2202b59276f55387fce758f2e54e27dc45c3553627371d4a2b62a8f2c86b23",
        "energy": "c769d6fbc0e50f0c8e221fa44f487be516d5152b9cebd6ee61e7e4ee83f7b3ae",
        "given": "4f549deeb8461e7dc92cbd057e99d7208e29bfb63218d38325e85e7ed4471435",
        "lost": "9d908ecfb6b256def8b49a7c504e6c889c4b0e41fe6ce3e01863dd7b61a20aa0",
        "received": "227c21a75b515bc79ca7664e1aff28e70cc2e9f516d4c0299059549de54b9e34",
        "seed": "316524109059c7b4016aa2fceee5f44923d3eb9cc3b1414ec96aa41d395e9a29",
        "series": "6ff74d4f6198f34ef18c24416f4f0b420c5290b5b2a27eee6076ca9afaf3f9cd",
        "shared": "0759840f38bedec28f9b2603fb8e705950c5175c2f8539ee2be21792e11bdc61",
        "trial": "e2e2033ae7e19d680599d4eb0a1359a2b48ec5baac75066c317fbf85159c54ef",
        "work": "fc514dd05f9e67dd8f546e15e783493b357abe54cd49701db6b543c53cf2aeec",
        "work_energy": "518f3ea7a24660b513e752556bd56514b213f3e58956c05221896a12db2098b4",
    },
}


def digest(array):
    """SHA-256 (hex) of ``array``'s values as contiguous little-endian bytes."""
    array = np.asarray(array)
    return hashlib.sha256(np.ascontiguousarray(array, array.dtype.newbyteorder("<"))
                          .tobytes()).hexdigest()


def digests(params):
    """{array name: digest} of one simulated configuration."""
    result = simulate(params)
    return {name: digest(result[name]) for name in ARRAYS}


@pytest.mark.parametrize("run", sorted(RUNS))
def test_replenishment_fingerprint(run):
    assert digests(RUNS[run]) == EXPECTED[run]


def test_digest_sees_one_bit():
    """The fingerprint would fail on a last-bit change of any value."""
    values = np.array([0.1, 0.2, 0.3])
    nudged = values.copy()
    nudged[1] = np.nextafter(nudged[1], 1.0)
    assert digest(values) != digest(nudged)
