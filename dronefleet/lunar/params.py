"""Parameters of the lunar foraging-with-recharging model (docs/guide/lunar.md).

:class:`LunarParams` holds one configuration: one field per config key, with the spec's defaults
(section 3) and the options of section 17. It does not validate: ``dronefleet.lunar.scenario``
checks every value before a kernel sees it. Units: metres, seconds, watts, joules (battery in Wh).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["LunarParams", "LAYOUTS", "OPTIONS"]

#: Scenario layouts of section 2: no obstacle, or a hard/soft obstacle between R-T, N-T or N-R.
LAYOUTS = ("OPEN", "HARD-RT", "SOFT-RT", "HARD-NT", "SOFT-NT", "HARD-NR", "SOFT-NR")

#: Allowed words of the section-17 options (the first is the default).
OPTIONS = {
    "avoidance": ("offset", "turn"),
    "broadcast_velocity": ("planned", "motion"),
    "broadcast": ("tick", "update"),
    "weight_form": ("exponent", "bracket", "literal"),
    "fallback": ("visited", "literal"),
    "turn_on": ("region", "any"),
    "redecide": ("none", "avoid_clear", "beacon_change"),
    "completion": ("role", "last_region"),
    "depletion": ("fatal", "recorded"),
    "experience": ("any", "leaving"),
    "model": ("full", "baseline"),
}


@dataclass(frozen=True)
class LunarParams:
    """One configuration of the lunar model (spec sections 2, 3, 11-14, 17)."""

    # world (section 2)
    layout: str = "SOFT-RT"
    """Scenario layout, one of :data:`LAYOUTS` (section 2)."""
    layout_scale: float = 0.75
    """Scale about the origin of region centres, field and obstacle corners [-] (A5; 1.0 = draft)."""
    # swarm and control (section 3)
    n_robots: int = 50
    """N_a, robots [-]."""
    tau: float = 0.064
    """Control step (one tick) [s]."""
    update_interval_s: float = 10.0
    """T, heading-decision and beacon-window interval [s]; n_T = floor(T / tau) ticks (A2)."""
    decision_step_m: float = 0.0
    """A1: > 0, a mobile robot also decides each time it has driven this far since its last decision [m]."""
    rho_w: float = 0.1
    """Potential-weight evaporation rate per window [-] (Eq 5-11)."""
    rho_v: float = 0.1
    """Guidance-vector update weight [-] (Eq 5-12)."""
    rho_p: float = 0.1
    """SOC-cost learning weight [-] (Eq 5-13)."""
    rho_f: float = 1.0
    """Exponent of omega in the guidance weight [-] (Eq 5-14, A12)."""
    rho_c: float = 3.0
    """Exponent of (1 - SOC_b) in the guidance weight [-] (Eq 5-14, A12)."""
    comm_radius: float = 2.0
    """delta_comm, communication radius (strict <) [m]."""
    eta_w: float = 1e-4
    """Beacon decay threshold on the summed potential weights [-]."""
    phi_soc: float = 1.25
    """phi_SOC, safety factor on the learned SOC cost [-]."""
    v0: float = 1.25
    """Ground speed [m/s] (A1)."""
    eps: float = 0.05
    """Exploration probability per heading decision [-]."""
    reward: float = 1.0
    """r, reward for being inside the region just completed [-] (Eq 4-6)."""
    diffusion: float = 0.8
    """lambda, diffusion rate of the state potential [-] (Eq 4-7)."""
    kappa_soft: float = 3.0
    """Locomotion power multiplier inside the soft obstacle [-] (A7)."""
    # energy (section 8)
    battery_wh: float = 10.0
    """E_cap, battery capacity [Wh]."""
    soc0: float = 1.0
    """Initial state of charge [-] (A39)."""
    soc0_low: float = 0.0
    """A39: if > 0, each robot's initial SOC is drawn from U(soc0_low, soc0); 0: every robot starts at soc0 [-]."""
    energy_scale: float = 1.0
    """A8: factor on every consumption term (p_move .. e_exploit; not p_solar) [-]."""
    r_max: int = 6
    """Resource units loaded per visit to T [units] (A11)."""
    p_move: float = 58.0
    """Locomotion power on normal ground while translating [W] (A8)."""
    p_comp: float = 1.0
    """Computation power, every alive robot [W]."""
    p_comm: float = 0.05
    """Power per active communication link [W]."""
    p_scan: float = 1.0
    """Scanning power, mobile roles only [W]."""
    p_avoid: float = 2.0
    """Extra power while obstacle avoidance is active [W]."""
    e_exploit: float = 100.0
    """Energy per load at T [J]."""
    p_solar: float = 102.075
    """Solar input inside R (0 outside) [W] (0.30 * 1361 * 0.25, A9)."""
    # bodies and sensing (A28, A29)
    r_body: float = 0.15
    """Robot disc radius [m] (A29)."""
    ir_range: float = 0.3
    """d_IR, IR ray reach beyond the body [m] (7.4)."""
    blocked_ticks: int = 10
    """Consecutive blocked ticks before a random turn [ticks] (7.5)."""
    # runs (sections 13, 14)
    duration_s: float = 3600.0
    """T_run, run length [s] (A10); K = floor(T_run / tau) ticks."""
    runs: int = 50
    """Runs of the configuration, run in one kernel call [-]."""
    first_run: int = 0
    """Index of the first run [-]; run j draws the same per-robot streams in every scenario."""
    seed: int = 0
    """Root seed of the experiment [-] (section 13)."""
    # records (sections 12, 19)
    rate_window_s: float = 100.0
    """W_rate, window of the rate of return [s] (A34)."""
    snapshot_every_s: float = 300.0
    """Interval of the periodic network snapshots [s] (section 19)."""
    frames: bool = False
    """Record a snapshot ("frame") every n_T ticks (or every ``frame_every_s``) for the replay [-]."""
    frame_every_s: float = 0.0
    """Interval of the frames [s]; 0: every n_T ticks (paths between frames are straight strokes)."""
    # options of section 17
    avoidance: str = "offset"
    """A28: "offset" (deviation from the plan while sensed) or "turn" (the turn becomes the plan)."""
    broadcast_velocity: str = "planned"
    """A28: robots broadcast their planned velocity v_m ("planned") or this tick's motion ("motion")."""
    broadcast: str = "tick"
    """A4: mobile robots broadcast every tick ("tick") or only at their heading decisions ("update")."""
    weight_form: str = "exponent"
    """A12: guidance weight omega^rho_f (1-S)^rho_c, "bracket" omega max(0, 1 - rho_c S), "literal" omega (1-S)."""
    fallback: str = "visited"
    """A18: R -> nest fallback only after visiting R ("visited") or always ("literal")."""
    turn_on: str = "region"
    """A26: turn around on role changes inside a region and at decay ("region") or on every change ("any")."""
    los_bodies: bool = False
    """A30: robot bodies occlude communication [-]."""
    redecide: str = "none"
    """A41: extra heading decisions: none, when avoidance clears, or when the nearest beacon changes."""
    completion: str = "role"
    """A17: completion by role and rows 9/11 ("role") or by the last region visited ("last_region")."""
    depletion: str = "fatal"
    """A32: SOC 0 kills ("fatal") or is counted and the robot goes on towards R ("recorded")."""
    experience: str = "any"
    """Sec 4-1-3: beacons take messages from every robot ("any") or from robots leaving region(s_c) ("leaving")."""
    model: str = "full"
    """E5: the Ch 5 model ("full") or the Ch 4 baseline ("baseline": no energy, roles F_OUT, F_IN, B only)."""

    @property
    def n_T(self) -> int:
        """Ticks per update interval: floor(T / tau + 1e-9) (156 at the defaults, A2)."""
        return math.floor(self.update_interval_s / self.tau + 1e-9)

    @property
    def ticks(self) -> int:
        """K, ticks per run: floor(T_run / tau + 1e-9) (56,250 at the defaults)."""
        return math.floor(self.duration_s / self.tau + 1e-9)

    @property
    def e_cap_j(self) -> float:
        """E_cap in joules (battery_wh * 3600)."""
        return self.battery_wh * 3600.0

    @property
    def rate_window_ticks(self) -> int:
        """W_rate in ticks: floor(W_rate / tau + 1e-9)."""
        return math.floor(self.rate_window_s / self.tau + 1e-9)

    @property
    def snapshot_every_ticks(self) -> int:
        """Periodic snapshot interval in ticks: floor(snapshot_every_s / tau + 1e-9)."""
        return math.floor(self.snapshot_every_s / self.tau + 1e-9)

    @property
    def frame_every_ticks(self) -> int:
        """Frame interval in ticks: n_T when ``frame_every_s`` is 0, else floor(frame_every_s / tau + 1e-9)."""
        return self.n_T if self.frame_every_s == 0 else math.floor(self.frame_every_s / self.tau + 1e-9)
