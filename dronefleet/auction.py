"""Winner rules: who bids, with what score, in an auction (MODEL.md section 7).

A rule is one compiled function with the signature::

    rule(f, w_norm, soc, theta, rng) -> (bids: bool, score: float)

called for every idle UAV in id order, where ``f`` is the UAV's policy decision
value for the advertised order, ``w_norm`` the L2 norm of its policy weights,
``soc`` its state of charge (percent), ``theta`` the config's threshold and
``rng`` the run's random-bid stream (a numpy Generator). Among the bidders the
highest score wins and ties go to the highest UAV id, so every bidder can
evaluate the outcome locally. A rule that wants the lowest value to win
returns its negation as the score.

Adding a rule: write the compiled function and ``register`` it under a name,
saying when it bids. The engine uses that to jump over advertisement ticks at
which provably nobody can bid (the result is the same as evaluating every tick):

- ``"policy"``: the rule bids exactly when f >= 0;
- ``"soc_threshold"``: it bids exactly when SoC >= theta;
- ``"any"``: anything else (every tick is evaluated).
"""

from typing import NamedTuple

from numba import njit

BIDS_ON = {"policy": 0, "soc_threshold": 1, "any": 2}


@njit(cache=True)
def least_confident(f, w_norm, soc, theta, rng):
    """Bid iff f >= 0; the lowest confidence f / ||w|| wins."""
    if f >= 0.0:
        return True, -(f / w_norm)
    return False, 0.0


@njit(cache=True)
def most_confident(f, w_norm, soc, theta, rng):
    """Bid iff f >= 0; the highest confidence f / ||w|| wins."""
    if f >= 0.0:
        return True, f / w_norm
    return False, 0.0


@njit(cache=True)
def random(f, w_norm, soc, theta, rng):
    """Bid iff f >= 0 with a value drawn from U(0, 1); the highest wins."""
    if f >= 0.0:
        return True, rng.random()
    return False, 0.0


@njit(cache=True)
def threshold(f, w_norm, soc, theta, rng):
    """Bid iff SoC >= theta, whatever the policy says; the highest SoC wins."""
    if soc >= theta:
        return True, soc
    return False, 0.0


class Rule(NamedTuple):
    """A registered winner rule: its compiled function and when it bids (a key of ``BIDS_ON``)."""

    kernel: object
    bids_on: str


RULES = {}


def register(name, kernel, bids_on="policy"):
    """Make the compiled ``kernel`` available as ``auction.rule = name`` in configs."""
    if not hasattr(kernel, "py_func"):
        raise TypeError(f"winner rule {name!r} must be a numba-compiled function (@njit)")
    if bids_on not in BIDS_ON:
        raise ValueError(f"bids_on of winner rule {name!r} must be one of {sorted(BIDS_ON)}, got {bids_on!r}")
    RULES[name] = Rule(kernel, bids_on)


register("least_confident", least_confident)
register("most_confident", most_confident)
register("random", random)
register("threshold", threshold, bids_on="soc_threshold")
