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
