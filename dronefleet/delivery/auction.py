"""Winner rules: who bids, with what score, in an auction (docs/delivery-model.md section 7).

A rule is one compiled function with the signature::

    rule(f, w_norm, soc, theta, rng) -> (bids: bool, score: float)

called for every idle UAV in id order, where ``f`` is the UAV's policy decision
value for the advertised order, ``w_norm`` the L2 norm of its policy weights,
``soc`` its state of charge (percent), ``theta`` the config's threshold and
``rng`` the run's random-bid stream (a numpy Generator). Among the bidders the
highest score wins and ties go to the highest UAV id, so every bidder can
evaluate the outcome locally. A rule that wants the lowest value to win
returns its negation as the score.

Every rule declares ``bids_on``, which lets the engine jump over advertisement ticks
at which provably nobody can bid (the result is the same as evaluating every tick):

- ``"policy"``: the rule bids exactly when f >= 0;
- ``"soc_threshold"``: it bids exactly when SoC >= theta;
- ``"any"``: anything else (every tick is evaluated).

A rule that bids otherwise than it declares gives results that depend on the skipped ticks.

Built-in rules have a code in ``RULES`` and a branch in ``bid``: the dispatch is static
code, so the engine is compiled once and loaded from numba's disk cache.

Plugin rules (no change to the package): the config's ``rule`` is either the name of an
entry point in the group ``dronefleet.winner_rules`` or a dotted path
``"package.module:function"``. Either names a numba ``@njit`` function of the signature
above, returning ``(bool, float)``, with an attribute ``bids_on`` (one of the three above)::

    @njit(cache=True)
    def lowest_soc(f, w_norm, soc, theta, rng):
        if f >= 0.0:
            return True, -soc
        return False, 0.0

    lowest_soc.bids_on = "policy"

The engine receives a plugin as a first-class function (numba ``FunctionType`` of
``RULE_SIGNATURE``): one compilation of the engine, disk-cached like the built-in one,
serves every plugin, and calls the plugin through a pointer (no inlining). Each process
compiles the plugin itself once unless it is ``cache=True``. :func:`resolve_rule` loads
and checks a rule by name, including what the rule returns of itself (numba would convert a
(score, bids) pair to the signature). While running, a bidder's score must be finite and the
rule must not raise: the run stops with a :class:`PluginError` naming it. Plugins cannot be
``base_rule`` of ``reservation``. An entry point named like a built-in rule is not used (a
warning says so): its dotted path is.

Files are data: a config read back from a file (a run's tables, a saved fleet, a sweep's
dataset) may name a plugin, but only the user's own config (TOML file, ``--set``, API argument)
may make dronefleet import one. :func:`rule_name_problem` checks a name read from a file
without loading anything: a ``"module:function"`` path is kept as the name it is.

``reservation`` (docs/delivery-model.md section 9) is not a kernel of this kind: it lets a base rule
(config ``base_rule``) resolve the immediate bids and adds reservation bids, whose
forecast is :func:`reservation_wait`; the engine runs the two phases.
"""

import functools
import importlib
import logging
import re
from importlib.metadata import entry_points
from typing import NamedTuple

import numpy as np
from numba import typeof, types
from numba.core import compiler, typed_passes
from numba.core.compiler_lock import global_compiler_lock
from numba.core.compiler_machinery import FunctionPass, register_pass
from numba.core.dispatcher import Dispatcher
from numba.core.errors import NumbaError
from numba.core.registry import cpu_target

from ..config import ConfigError, _suggest, brief
from ..fpmath import log
from ..jit import borrowing, njit
from ..plugins import IMPORT_NOTICE_S, importing  # read at each import: tests shorten it

logger = logging.getLogger(__name__)  # not ``log``: that is fpmath's logarithm here

BIDS_ON = {"policy": 0, "soc_threshold": 1, "any": 2}

#: Entry-point group of plugin rules: name -> compiled rule function.
ENTRY_POINT_GROUP = "dronefleet.winner_rules"
#: The code of every plugin rule: the engine calls its kernel instead of ``bid``'s branches.
PLUGIN = -2
#: What the engine passes to a rule and expects back (see the module doc).
RULE_ARGS = (types.float64, types.float64, types.float64, types.float64, typeof(np.random.default_rng(0)))
RULE_SIGNATURE = types.Tuple((types.boolean, types.float64))(*RULE_ARGS)


@borrowing
def least_confident(f, w_norm, soc, theta, rng):
    """Bid iff f >= 0; the lowest confidence f / ||w|| wins."""
    if f >= 0.0:
        return True, -(f / w_norm)
    return False, 0.0


@borrowing
def most_confident(f, w_norm, soc, theta, rng):
    """Bid iff f >= 0; the highest confidence f / ||w|| wins."""
    if f >= 0.0:
        return True, f / w_norm
    return False, 0.0


@borrowing
def random(f, w_norm, soc, theta, rng):
    """Bid iff f >= 0 with a value drawn from U(0, 1); the highest wins."""
    if f >= 0.0:
        return True, rng.random()
    return False, 0.0


@borrowing
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

    ``code`` selects it in ``bid`` (``PLUGIN``: a plugin, called through ``kernel``), ``kernel``
    is its compiled function, ``bids_on`` (a key of ``BIDS_ON``) says when it bids, and
    ``reserves`` marks the reservation variant, which runs a base rule's kernel for the
    immediate bids.
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


class RuleError(ValueError):
    """A rule name that names no usable rule; the message completes "rule = 'name' ..."."""


class PluginError(ConfigError):
    """A plugin rule broke its contract while a run used it (it raised, or scored a bid NaN or infinite)."""


def plugin_name(kernel) -> str:
    """``module:function`` of a plugin rule's compiled function, to name it in messages."""
    return f"{kernel.py_func.__module__}:{kernel.py_func.__qualname__}"


def installed_plugins() -> tuple[str, ...]:
    """Names of the plugin rules installed as entry points, sorted."""
    return tuple(sorted(ep.name for ep in entry_points(group=ENTRY_POINT_GROUP)))


def resolve_rule(name: str) -> Rule:
    """The rule called ``name``: built in, an installed entry point, or ``"module:function"``.

    Raises :class:`RuleError` saying what is wrong and what is allowed.
    """
    if name in RULES:
        _warn_if_shadowed(name)
        return RULES[name]
    return _plugin(name)


def rule_name_problem(name: str) -> str | None:
    """Why ``name``, read from a file, names no rule (the end of a one-line message), or None.

    Nothing is imported or loaded: a built-in rule, the name of an installed entry point (read
    from the installed packages' metadata) or a well-formed ``"package.module:function"`` path
    (kept as a name: the file does not choose what code runs) is accepted.
    """
    if name in RULES:
        return None
    if ":" in name:
        module_name, _, attribute = name.partition(":")
        dotted = module_name.split(".") + attribute.split(".")
        if all(part.isidentifier() for part in dotted):
            return None
        return "is not a well-formed plugin path 'package.module:function'"
    if entry_points(group=ENTRY_POINT_GROUP, name=name):
        return None
    names = tuple(RULES) + installed_plugins()
    return (f"is not a registered winner rule{_suggest(name, names)}. Allowed: {', '.join(map(repr, names))}, "
            "or a plugin's 'package.module:function'")


@functools.cache  # once per name and process: validation resolves the rule of every run
def _warn_if_shadowed(name: str) -> None:
    """Warn that an entry point named like the built-in rule ``name`` is not what runs."""
    for entry_point in entry_points(group=ENTRY_POINT_GROUP, name=name):
        logger.warning(f"dronefleet: warning: the {ENTRY_POINT_GROUP} entry point {name!r} ({entry_point.value}) "
                       f"is not used: {name!r} is the built-in rule; name the plugin by its path "
                       f"{entry_point.value!r}")


@functools.cache  # successes only: a failed lookup raises, and is tried again next time
def _plugin(name: str) -> Rule:
    if ":" in name:
        kernel = _import_path(name)
    else:
        found = entry_points(group=ENTRY_POINT_GROUP, name=name)
        if not found:
            names = tuple(RULES) + installed_plugins()
            raise RuleError(f"is not a registered winner rule{_suggest(name, names)}. Allowed: "
                            f"{', '.join(map(repr, names))}, or a plugin's 'package.module:function'")
        entry_point = next(iter(found))
        try:
            with importing(entry_point.module, f"winner rule {name!r}", IMPORT_NOTICE_S):
                kernel = entry_point.load()
        except Exception as e:  # the plugin's own error, whatever it is: the user must see it
            raise RuleError(f"is an entry point of {ENTRY_POINT_GROUP} ({entry_point.value}) that fails to "
                            f"load: {type(e).__name__}: {brief(e)}") from None
    return _checked(kernel)


def _import_path(path: str):
    """The object at ``"package.module:attribute"``."""
    module_name, _, attribute = path.partition(":")
    try:
        with importing(module_name, f"winner rule {path!r}", IMPORT_NOTICE_S):
            module = importlib.import_module(module_name)
    except Exception as e:  # ImportError, or whatever the module raises on import
        raise RuleError(f"names module {module_name!r}, which cannot be imported ({type(e).__name__}: {brief(e)}); "
                        "allowed: a built-in rule, an installed plugin or 'package.module:function'") from None
    try:
        with importing(module_name, f"winner rule {path!r}", IMPORT_NOTICE_S):  # a module __getattr__ runs code too
            return functools.reduce(getattr, attribute.split("."), module)
    except AttributeError:
        raise RuleError(f"names {attribute!r}, which module {module_name!r} does not have") from None
    except Exception as e:  # a module __getattr__ or property of the plugin's that raises
        raise RuleError(f"names {attribute!r}, which module {module_name!r} fails to give "
                        f"({type(e).__name__}: {brief(e)})") from None


#: A terminal's colour/style escape sequence (ANSI SGR), as numba writes them around its messages.
_TERMINAL_COLOUR = re.compile(r"\x1b\[[0-9;]*m")


def _checked(kernel) -> Rule:
    """The plugin rule of ``kernel`` if it is a numba-compiled function of the contract (compiled for it here)."""
    if not isinstance(kernel, Dispatcher):
        raise RuleError(f"is a {type(kernel).__name__}, not a numba @njit function "
                        "rule(f, w_norm, soc, theta, rng) -> (bool, float)")
    bids_on = getattr(kernel, "bids_on", None)
    if not isinstance(bids_on, str) or bids_on not in BIDS_ON:  # a list would not even hash
        raise RuleError(f"has bids_on = {bids_on!r}; set the function's attribute bids_on to one of "
                        f"{', '.join(map(repr, BIDS_ON))} (see dronefleet.delivery.auction)")
    # An index out of an array's bounds is then an IndexError naming the rule, not a crash (SIGSEGV)
    # or a wrong score; a rule is a few operations of the auction, the check costs little.
    kernel.targetoptions["boundscheck"] = True
    try:
        # With the return type given, numba converts what the rule returns (a literal True, an int score).
        kernel.compile(RULE_SIGNATURE)
    except (NumbaError, TypeError) as e:  # TypeError: another number of arguments
        # numba colours its messages when colorama is installed: the escape codes are no text of ours
        plain = _TERMINAL_COLOUR.sub("", str(e))
        lines = [line.strip() for line in plain.splitlines() if line.strip()] or [type(e).__name__]
        # numba's first line names its failed pass; the cause and the plugin's line come after it
        cause = next((line for line in lines if not line.startswith("Failed in ")), lines[0])
        where = next((f" ({line.rstrip(':')})" for line in lines if line.startswith("File ")), "")
        raise RuleError(f"does not compile as rule(f, w_norm, soc, theta, rng) -> (bool, float) with floats "
                        f"and a numpy Generator: {cause}{where}") from None
    # An earlier call with the same arguments may have compiled it to return something else.
    returns = kernel.overloads[RULE_ARGS].signature.return_type
    if returns != RULE_SIGNATURE.return_type:
        raise RuleError(f"is compiled to return {returns}, not (bool, float64)")
    # Compiled for the return type, numba converts what the rule returns: a literal True or an
    # int score, but also a (score, bids) pair the wrong way round. What it returns of itself tells.
    returns = _own_return_type(kernel)
    if returns is not None and not (isinstance(returns, types.BaseTuple) and len(returns) == 2
                                    and isinstance(returns[0], types.Boolean)
                                    and isinstance(returns[1], (types.Float, types.Integer))):
        raise RuleError(f"returns {returns}, not (bids, score): a bool, then a float, in this order")
    return Rule(PLUGIN, kernel, bids_on)


@register_pass(mutates_CFG=False, analysis_only=True)
class _ReturnTypeResult(FunctionPass):
    """The last pass of :class:`_TypingPipeline`: its result is the return type numba inferred."""

    _name = "dronefleet_return_type_result"

    def __init__(self):
        FunctionPass.__init__(self)

    def run_pass(self, state):
        state.cr = state.return_type
        return False


class _TypingPipeline(compiler.CompilerBase):
    """numba's front end and type inference only (no code generated): ~20 ms for a rule."""

    def define_pipelines(self):
        passes = compiler.DefaultPassBuilder.define_untyped_pipeline(self.state)
        passes.add_pass(typed_passes.NopythonTypeInference, "nopython frontend")
        passes.add_pass(_ReturnTypeResult, "return type")
        passes.finalize()
        return [passes]


def _own_return_type(kernel):
    """The numba type a rule returns for RULE_ARGS when no return type is imposed; None if this
    front end cannot tell (the rule compiled for the contract already, with numba's own pipeline)."""
    flags = compiler.Flags()
    flags.nrt = True  # as @njit: a rule may allocate (np.zeros)
    try:
        with global_compiler_lock:
            return compiler.compile_extra(cpu_target.typing_context, cpu_target.target_context, kernel.py_func,
                                          RULE_ARGS, None, flags, {}, pipeline_class=_TypingPipeline)
    except NumbaError:
        return None


@borrowing
def bid(rule, kernel, f, w_norm, soc, theta, rng):
    """Whether a UAV bids and its score under the rule with code ``rule`` (see ``RULES``).

    ``kernel`` is None for a built-in rule (the branch below is then compiled away) and a
    plugin's function (of type ``FunctionType(RULE_SIGNATURE)``) for ``PLUGIN``.
    """
    if kernel is not None:
        return kernel(f, w_norm, soc, theta, rng)
    if rule == 0:
        return least_confident(f, w_norm, soc, theta, rng)
    if rule == 1:
        return most_confident(f, w_norm, soc, theta, rng)
    if rule == 2:
        return random(f, w_norm, soc, theta, rng)
    return threshold(f, w_norm, soc, theta, rng)
