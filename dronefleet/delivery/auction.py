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

``reservation`` (MODEL.md section 9) is not a kernel of this kind: it lets a base rule
(config ``base_rule``) resolve the immediate bids and adds reservation bids, whose
forecast is :func:`reservation_wait`; the engine runs the two phases.
"""

from typing import NamedTuple

import numpy as np
from numba import njit

from ..fpmath import log

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


@njit(cache=True)
def reservation_wait(f_soc, w_soc, soc, soc_mean, soc_std, charge_rate):
    """The reservation bid of a UAV that would not bid now: its forecast wait [s], or inf.

    ``f_soc`` is the UAV's decision value for the order without the SoC term (w . x~ + b
    with the SoC feature at 0), ``w_soc`` the SoC weight (standardised feature), ``soc`` the
    current SoC [%], ``charge_rate`` k [1/s]. The UAV needs the SoC s* with f = 0; it
    reserves only if f grows with SoC (w_soc > 0) and s* < 100 (at s* = 100 the charging
    curve never gets there). The wait is the inverse of the charging curve,
    ln((100 - SoC) / (100 - s*)) / k.
    """
    if w_soc <= 0.0:
        return np.inf
    need = soc_mean - soc_std * f_soc / w_soc
    if need >= 100.0:
        return np.inf
    if need <= soc:  # the caller asks only when f < 0; rounding can put s* a hair below SoC
        return 0.0
    return log((100.0 - soc) / (100.0 - need)) / charge_rate


class Rule(NamedTuple):
    """A registered winner rule.

    ``code`` selects it in ``bid``, ``kernel`` is its compiled function, ``bids_on`` (a key
    of ``BIDS_ON``) says when it bids, and ``reserves`` marks the reservation variant,
    which runs a base rule's kernel for the immediate bids.
    """

    code: int
    kernel: object
    bids_on: str
    reserves: bool = False


RULES = {
    "least_confident": Rule(0, least_confident, "policy"),
    "most_confident": Rule(1, most_confident, "policy"),
    "random": Rule(2, random, "policy"),
    "threshold": Rule(3, threshold, "soc_threshold"),
    "reservation": Rule(-1, reservation_wait, "policy", reserves=True),
}

#: Rules that can resolve the immediate bids of ``reservation``: those that bid on their policy.
BASE_RULES = tuple(name for name, rule in RULES.items() if rule.bids_on == "policy" and not rule.reserves)


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
