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

Adding a rule: write the compiled function, give it the next code in ``RULES``
(saying when it bids) and a branch in ``bid``. The dispatch is static code because
numba's disk cache cannot key a kernel on a function passed as argument (every new
process would recompile the engine). ``bids_on`` lets the engine jump over
advertisement ticks at which provably nobody can bid (the result is the same as
evaluating every tick):

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
    """A registered winner rule: its code in ``bid``, its kernel and when it bids (a key of ``BIDS_ON``)."""

    code: int
    kernel: object
    bids_on: str


RULES = {
    "least_confident": Rule(0, least_confident, "policy"),
    "most_confident": Rule(1, most_confident, "policy"),
    "random": Rule(2, random, "policy"),
    "threshold": Rule(3, threshold, "soc_threshold"),
}


@njit(cache=True)
def bid(rule, f, w_norm, soc, theta, rng):
    """Whether a UAV bids and its score under the rule with code ``rule`` (see ``RULES``)."""
    if rule == 0:
        return least_confident(f, w_norm, soc, theta, rng)
    if rule == 1:
        return most_confident(f, w_norm, soc, theta, rng)
    if rule == 2:
        return random(f, w_norm, soc, theta, rng)
    return threshold(f, w_norm, soc, theta, rng)
