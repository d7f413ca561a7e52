"""The stepping controller: compiled chunks of steps, Python trackers between them.

The controller calls ``advance(n)`` (the compiled loop) for a chunk of steps, then hands the run
to each tracker in turn: observers (the history, the zig-zag diagnostic, the field recorder,
progress) look; guards (non-finite values, energy runaway, soil speed, out of domain, rest,
bearing failure, the push's end, the travel the domain was sized for, the step budget) may end
the run with a status and a message. Nothing slow sits in the compiled loop, and each guard is a
small object with its own test.

Every tracker is a :class:`Tracker`: ``start`` once the first call has compiled, ``after_chunk`` after
each chunk it is due for, ``finish`` at the end. *When* it looks is its :class:`Cadence`. Most look
after every chunk (:data:`EVERY_CHUNK`); the scans, which pass over the whole state (the zig-zag
diagnostic and the guards on non-finite values, the soil law's output, kinetic energy and soil
speed), look every :data:`SCAN_STEPS` steps (:class:`EverySteps`), and whenever the compiled loop
stopped early or another tracker ends the run (they then have the last word, as they come first). A
chunk is one history sample, which on a coarse 3D grid is a few steps; the compiled loop itself
checks every step that the body's velocity and force are finite and that no soil outran a cell.

Interrupts: SIGINT and SIGTERM only raise a flag, which the controller reads between compiled
calls. A chunk (one history sample) is stepped in slices of about ``POLL_S`` of wall time, so a
signal ends the run within about that, with status ``interrupted``. The slicing does not change
the result: the compiled loop keeps its whole state in the containers, so n + m steps in two calls
are bit for bit n + m steps in one, and trackers only look at whole chunks.
"""

from __future__ import annotations

import math
import signal
import sys
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from typing import Callable, Optional

import numpy as np

from dsmv.cel import ledger
from dsmv.cel.kernels.common import all_finite
from dsmv.cel.layout import (
    B_FCOUNT, B_MAXDISP, B_MAXEDGE, B_MAXROT, B_MAXSLIDE, B_OFFSET, B_OFFSET_X, B_OFFSET_Y, B_ROT_X, B_ROT_Y, B_ROT_Z,
    B_SINKAGE, B_TIME, B_VEL, B_VX, B_VY, FORCE_SLOTS, FREEDOMS, POSE_SLOTS,
)
from dsmv.cel.stepper import AT_REST, NOT_FINITE, OUTRAN, RUNNING


@dataclass(frozen=True)
class Ending:
    """Why a run stopped: its status (``ok``, ``unstable``, ``out_of_domain``, ``bearing_failure``) and message."""

    status: str
    message: str


@dataclass
class Run:
    """What trackers see between chunks: the state containers, the body and energy arrays, the
    exit code of the last chunk, the steps done and the run's constants."""

    state: object          # the solver's state (containers and arrays; see dsmv.cel.solver.State)
    body: np.ndarray
    energy: np.ndarray
    code: int = RUNNING
    steps: int = 0
    force_scale: float = 1.0     # model force → force per track
    message: str = ""            # the ok run's message, set by the tracker that knows
    start_sinkage_m: float = 0.0  # the sinkage the body starts with (a trapped-soil track's grouser height)
    history: dict = field(default_factory=lambda: {"time_s": [], "sinkage_m": [], "velocity_m_s": [], "force_n": []})

    @property
    def time_s(self) -> float:
        return float(self.body[B_TIME])

    @property
    def travel_m(self) -> float:
        """How far the middle of the body's base has gone down since the start (m, down +)."""
        return float(self.body[B_SINKAGE])

    @property
    def sinkage_m(self) -> float:
        return self.start_sinkage_m + self.travel_m

    @property
    def turned_deg(self) -> float:
        """How far the body has turned, the size of its rotation (degrees)."""
        return math.degrees(math.sqrt(sum(float(self.body[s]) ** 2 for s in (B_ROT_X, B_ROT_Y, B_ROT_Z))))

    @property
    def max_sinkage_m(self) -> float:
        return self.start_sinkage_m + float(self.body[B_MAXDISP])

    def mean_reaction(self, slot: int) -> float:
        """The soil's mean force or moment on the body over the last chunk, per track, from its sum in ``slot``."""
        return self.force_scale * self.body[slot] / max(self.body[B_FCOUNT], 1.0)

    @property
    def force_n(self) -> float:
        """The soil's mean force on the body over the last chunk, per track (N, up +)."""
        return self.mean_reaction(FORCE_SLOTS[2])

    def column(self, name: str) -> float:
        """A history column of a body that slides or turns (:data:`MOTION_COLUMNS`): the soil's mean force
        (N) or moment about the centre of gravity (N·m) over the last chunk, per track, or the body's
        displacement (m) or rotation (degrees) now."""
        kind, q = MOTION_COLUMNS[name]
        if kind == "reaction":
            return self.mean_reaction(FORCE_SLOTS[q])
        value = float(self.body[POSE_SLOTS[q]])
        return math.degrees(value) if q >= 3 else value


#: the history's columns of a body that slides or turns: what each is and its freedom (dsmv.cel.layout.FREEDOMS);
#: plane strain has the first four (x, and the turn about y), 3D all. Moments and rotations follow the right
#: hand: + about y lowers the +x side, about x raises the +y end, about z turns +x towards +y.
MOTION_COLUMNS = {
    "horizontal_force_n": ("reaction", 0), "moment_n_m": ("reaction", 4),
    "rotation_deg": ("pose", 4), "horizontal_displacement_m": ("pose", 0),
    "lateral_force_n": ("reaction", 1), "pitch_moment_n_m": ("reaction", 3), "yaw_moment_n_m": ("reaction", 5),
    "pitch_deg": ("pose", 3), "yaw_deg": ("pose", 5), "lateral_displacement_m": ("pose", 1),
}


class Cadence:
    """When a tracker looks: after every chunk (this base), or less often (:class:`EverySteps`). A run
    that stops, early or by another tracker's ending, is shown to every tracker before it ends."""

    def due(self, run: Run, last_look: int) -> bool:
        """Whether to look now, ``last_look`` the step of the tracker's last look."""
        return True


@dataclass(frozen=True)
class EverySteps(Cadence):
    """Look once ``steps`` steps have passed since the last look, or when the compiled loop stopped early."""

    steps: int

    def due(self, run: Run, last_look: int) -> bool:
        return run.code != RUNNING or run.steps - last_look >= self.steps


#: wall time between two looks at the interrupt flag (s)
POLL_S = 0.25
#: steps at least between two looks of the scans: on the 3D push at B/10 (28,800 cells, a history
#: sample every 3.8 steps) looking every sample cost 9-12 % of the run, a pass over the state each
SCAN_STEPS = 16
EVERY_CHUNK = Cadence()
#: the cadence of the trackers that pass over the whole state (decision 0022)
SCAN = EverySteps(SCAN_STEPS)
SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Tracker:
    """An observer or guard of a run, called between compiled chunks: ``start`` once the first call has
    compiled, ``after_chunk`` after each chunk its :attr:`cadence` makes it due for (a guard returns an
    :class:`Ending` to end the run, else None), ``finish`` when the run has ended. ``slow_start_notice``:
    a line to print when the first call (the compile) takes over a second."""

    cadence: Cadence = EVERY_CHUNK
    slow_start_notice: Optional[str] = None

    def start(self, run: Run) -> None:
        pass

    def after_chunk(self, run: Run) -> Optional[Ending]:
        return None

    def finish(self, run: Run) -> None:
        pass


class Controller:
    """Runs ``advance`` in chunks of ``chunk`` steps, with the trackers between, until one ends the run."""

    def __init__(self, advance: Callable[[int], tuple[int, int]], trackers: list[Tracker], chunk: int,
                 max_steps: int):
        self.advance, self.trackers, self.chunk, self.max_steps = advance, trackers, chunk, max_steps
        self.signal: Optional[int] = None
        self.slice = 1  # steps per compiled call, grown to about POLL_S of wall time
        self.last_look = [0] * len(trackers)  # the step of each tracker's last look

    def run(self, run: Run) -> tuple[Ending, float, float]:
        """Run to the end; returns the ending, the first call's time (compile or cache load, s) and
        the wall time of the rest (s)."""
        with self.catching_signals():
            t_start = time.perf_counter()
            notices = [t.slow_start_notice for t in self.trackers if t.slow_start_notice]
            timer = threading.Timer(1.0, lambda: print(*notices, file=sys.stderr, flush=True))
            if notices:
                timer.start()
            run.steps, run.code = self.advance(1)  # the first call compiles (or loads the cache)
            timer.cancel()
            compile_s = time.perf_counter() - t_start
            for tracker in self.trackers:
                tracker.start(run)
            t_run = time.perf_counter()
            while True:
                run.body[FORCE_SLOTS] = 0.0
                run.body[B_FCOUNT] = 0.0
                self.step_chunk(run)
                ending = self.interrupted(run) or self.look(run)
                if ending is not None:
                    break
            wall_s = time.perf_counter() - t_run
        for tracker in self.trackers:
            tracker.finish(run)
        return ending, compile_s, wall_s

    def step_chunk(self, run: Run) -> None:
        """One chunk of steps, in slices short enough to look at the interrupt flag between them."""
        left = min(self.chunk, self.max_steps - run.steps)
        while run.code == RUNNING and left > 0 and self.signal is None:
            n = min(self.slice, left)
            t0 = time.perf_counter()
            done, run.code = self.advance(n)
            elapsed = time.perf_counter() - t0
            run.steps += done
            left -= done
            if done == n:  # aim the next slice at POLL_S, growing at most tenfold
                self.slice = max(1, min(10 * n, int(n * POLL_S / max(elapsed, 1e-6))))

    def look(self, run: Run) -> Optional[Ending]:
        """The trackers due by their cadence, in turn; the first guard that ends the run says why. A run
        that ends is first shown to the trackers that were not due, whose ending then wins."""
        due = [k for k, t in enumerate(self.trackers) if t.cadence.due(run, self.last_look[k])]
        ending = self.look_with(run, due)
        if ending is not None and len(due) < len(self.trackers):
            waiting = [k for k in range(len(self.trackers)) if k not in due]
            ending = self.look_with(run, waiting) or ending
        return ending

    def look_with(self, run: Run, which: list[int]) -> Optional[Ending]:
        for k in which:
            self.last_look[k] = run.steps
            ending = self.trackers[k].after_chunk(run)
            if ending is not None:
                return ending
        return None

    def interrupted(self, run: Run) -> Optional[Ending]:
        if self.signal is None:
            return None
        name = signal.Signals(self.signal).name
        return Ending("interrupted", f"interrupted by {name} at t = {run.time_s:.4g} s, sinkage {run.sinkage_m:.4g} m")

    @contextmanager
    def catching_signals(self):
        """SIGINT and SIGTERM raise the flag instead of the default action, for the run's duration
        (main thread only: signal handlers cannot be set elsewhere)."""
        if threading.current_thread() is not threading.main_thread():
            yield
            return

        def raise_flag(signum, frame):
            self.signal = signum

        previous = {s: signal.signal(s, raise_flag) for s in SIGNALS}
        for handler in previous.values():  # a sweep's job caught one while it set the run up
            earlier = getattr(handler, "caught", {}).get("signal")
            self.signal = self.signal or earlier
        try:
            yield
        finally:
            for s, handler in previous.items():
                signal.signal(s, handler)


# ----------------------------------------------------------------------------- observers


class History(Tracker):
    """The time history: time, sinkage, the body's downward velocity and the soil's force, per chunk,
    from the touchdown on (the body's state then, ``touchdown``, a copy of its array); and the ``extra``
    columns of a body that slides or turns (:data:`MOTION_COLUMNS`)."""

    def __init__(self, touchdown: np.ndarray, extra: tuple[str, ...] = (), held: tuple[str, ...] = ()):
        self.touchdown = touchdown
        self.extra = extra
        self.zero = {name for name in extra if FREEDOMS[MOTION_COLUMNS[name][1]] in held}

    def value(self, run: Run, name: str) -> float:
        """A column's value: the whole body's, which is 0 for a freedom a symmetry plane holds (the model's
        part of the body feels the plane's reaction, its mirror image the opposite one)."""
        return 0.0 if name in self.zero else run.column(name)

    def start(self, run: Run) -> None:
        touchdown = replace(run, body=self.touchdown)  # the first row: before the first step
        for name, value in (("time_s", 0.0), ("sinkage_m", touchdown.sinkage_m),
                            ("velocity_m_s", -float(self.touchdown[B_VEL])), ("force_n", 0.0)):
            run.history[name].append(value)
        for name in self.extra:
            run.history[name] = [0.0 if MOTION_COLUMNS[name][0] == "reaction" else self.value(touchdown, name)]

    def after_chunk(self, run: Run) -> None:
        h = run.history
        h["time_s"].append(run.time_s)
        h["sinkage_m"].append(run.sinkage_m)
        h["velocity_m_s"].append(-run.body[B_VEL])
        h["force_n"].append(run.force_n)
        for name in self.extra:
            h[name].append(self.value(run, name))


class Zigzag(Tracker):
    """Σ over its looks (a scan) of the hourglass and linear velocity modes (m²/s²), for ``hourglass_mode_ratio``."""

    cadence = SCAN

    def __init__(self, modes: Callable[[], tuple[float, float]]):
        self.modes = modes
        self.sums = np.zeros(2)

    def after_chunk(self, run: Run) -> None:
        self.sums += np.array(self.modes())

    def ratio(self) -> float:
        if not np.isfinite(self.sums).all():  # a run gone unstable may have summed infinities
            return math.nan
        return math.sqrt(self.sums[0] / self.sums[1]) if self.sums[1] > 0 else 0.0


class Fields(Tracker):
    """The field recorder (dsmv.cel.fields), fed between chunks; writes its frames at the end."""

    def __init__(self, recorder, snapshot: Callable[[], tuple], run_dir):
        self.recorder, self.snapshot, self.run_dir = recorder, snapshot, run_dir

    def after_chunk(self, run: Run) -> None:
        self.recorder.sample(run.time_s, run.sinkage_m, *self.snapshot())

    def finish(self, run: Run) -> None:
        self.recorder.sample(run.time_s, run.sinkage_m, *self.snapshot(), final=True)
        self.recorder.write(self.run_dir)


class Progress(Tracker):
    """Progress of one run on stderr, in simulated time against the expected duration: a tqdm bar on
    a terminal (percentage, rate, time left), else a plain line every ``PLAIN_EVERY_S`` of wall time
    (a log or a pipe). A cold start says, after a second, that the kernels are compiling."""

    PLAIN_EVERY_S = 10.0
    slow_start_notice = "  compiling the CEL kernels (once; later runs load them from the cache) ..."

    def __init__(self, expected_s: float, terminal: bool, slides: bool = False, turns: bool = False):
        self.expected_s, self.terminal = max(expected_s, 1e-9), terminal
        self.slides, self.turns = slides, turns  # the body's freedoms beyond the vertical the line reports
        self.bar = None
        self.last = 0.0
        self.origin: Optional[tuple[float, float]] = None  # (wall, simulated) after the first chunk

    def time_left_s(self, run: Run) -> Optional[float]:
        """Wall time left (s): the simulated time left at the pace since the first chunk, which holds a
        cold start's compile (None until a second chunk has run)."""
        now = time.perf_counter()
        if self.origin is None:
            self.origin = (now, run.time_s)
            return None
        simulated = run.time_s - self.origin[1]
        if simulated <= 0 or run.time_s >= self.expected_s:  # past the expected duration nothing says how long
            return None
        return (now - self.origin[0]) * (self.expected_s - run.time_s) / simulated

    def start(self, run: Run) -> None:
        from tqdm import tqdm

        self.started = self.last = time.perf_counter()
        if self.terminal:
            self.bar = tqdm(total=self.expected_s, unit="s", desc="  simulated", file=sys.stderr, leave=False,
                            bar_format="{desc} {n:.3f}/{total:.3f} s {percentage:3.0f}%|{bar}| "
                                       "[{elapsed}<{remaining}] {postfix}")

    def line(self, run: Run) -> str:
        body = run.body
        moves = ""
        if self.slides:  # a slide along the seabed is what a long run on a slope is doing
            moves += (f", slid {math.hypot(body[B_OFFSET_X], body[B_OFFSET_Y]):.4f} m at "
                      f"{math.hypot(body[B_VX], body[B_VY]):.3f} m/s")
        sinkage = f"sinkage {run.sinkage_m:.4f} m"
        if self.turns:  # a tilted base's middle may stand above the mudline while its lowest point is deep in
            sinkage += (f" at the base's middle, its lowest point {run.start_sinkage_m + body[B_MAXEDGE]:.4f} m "
                        f"deep at most")
            moves += f", tilted {run.turned_deg:.2f}° ({math.degrees(body[B_MAXROT]):.2f}° at most)"
        return f"{sinkage}, velocity {0.0 - body[B_VEL]:.3f} m/s{moves}, {run.steps:,} steps"

    def where(self, run: Run) -> str:
        """The run's time against the expected duration in words; past it, that the body still moves (a
        landing comes to rest when the fast landing model says, a body that turns when its turn has
        settled, which no fast model gives)."""
        if run.time_s < self.expected_s:
            return f"{run.time_s / self.expected_s:4.0%} of the expected {self.expected_s:.3f} s"
        return f"past the expected {self.expected_s:.3f} s, still moving: no estimate of the time left"

    def after_chunk(self, run: Run) -> None:
        left = self.time_left_s(run)
        if self.bar is not None:
            if run.time_s > self.bar.total:  # past the expected duration: the bar shows no time left it cannot know
                self.bar.total = run.time_s
            self.bar.update(run.time_s - self.bar.n)
            past = "" if run.time_s < self.expected_s else "; " + self.where(run)
            self.bar.set_postfix_str(self.line(run) + past, refresh=False)
        elif time.perf_counter() - self.last >= self.PLAIN_EVERY_S:
            from tqdm import tqdm

            self.last = time.perf_counter()
            eta = "" if left is None else f", about {tqdm.format_interval(left)} left"
            print(f"  t = {run.time_s:.4f} s: {self.line(run)}; {self.where(run)} "
                  f"[{tqdm.format_interval(self.last - self.started)} elapsed{eta}]", file=sys.stderr, flush=True)

    def finish(self, run: Run) -> None:
        if self.bar is not None:
            self.bar.close()


# ----------------------------------------------------------------------------- guards


@dataclass
class LawOutput(Tracker):
    """A soil law whose factor came back negative or not finite (the kernels store NaN as that cell's
    strength): the plugin's fault, raised as a :class:`~dsmv.errors.PluginError` naming the law and
    the cell's state that produced it."""

    cadence = SCAN

    strength: Callable[[], np.ndarray]
    describe: Callable[[tuple], str]  # one cell's state in words (ξ, γ̇, the law's state variables)
    law: str

    def after_chunk(self, run: Run) -> Optional[Ending]:
        bad = np.argwhere(np.isnan(self.strength()))
        if bad.size:
            from dsmv.errors import PluginError

            cell = tuple(int(i) for i in bad[0])
            raise PluginError(f"soil.law = '{self.law}' returned a strength factor that is negative or not finite "
                              f"at {self.describe(cell)} (t = {run.time_s:.4g} s); its factor() must return a "
                              f"finite value ≥ 0")
        return None


@dataclass
class NonFinite(Tracker):
    """A NaN or infinity anywhere in the state, or soil gone a whole cell between remaps: unstable."""

    cadence = SCAN

    arrays: Callable[[], list]
    cfl: float

    def after_chunk(self, run: Run) -> Optional[Ending]:
        if run.code == OUTRAN:
            return Ending("unstable", f"soil crossed a whole cell between two remaps at t = {run.time_s:.4g} s, "
                                      f"as only an unstable step makes it; lower solver.cfl (now {self.cfl})")
        if run.code == NOT_FINITE or not all(all_finite(a) for a in self.arrays()):
            return Ending("unstable", f"a non-finite value appeared at t = {run.time_s:.4g} s; lower solver.cfl "
                                      f"(now {self.cfl}) or raise solver.bulk_viscosity_linear")
        return None


@dataclass
class EnergyRunaway(Tracker):
    """The soil's kinetic energy past ten times the energy put in: unstable."""

    cadence = SCAN

    kinetic: Callable[[], float]
    kinetic_in: float
    scale: float
    cfl: float

    def after_chunk(self, run: Run) -> Optional[Ending]:
        kinetic = self.kinetic()
        if kinetic > 10.0 * ledger.delivered(run.energy, self.kinetic_in) + 1e-9:
            return Ending("unstable", f"the soil's kinetic energy ({kinetic * self.scale:.3g} J) ran away past ten "
                                      f"times the energy put in at t = {run.time_s:.4g} s; lower solver.cfl "
                                      f"(now {self.cfl})")
        return None


@dataclass
class SpeedLimit(Tracker):
    """A soil speed past 50 times the scene's own speeds: unstable."""

    cadence = SCAN

    speed: Callable[[], float]
    limit: float
    cfl: float
    hourglass: float

    def after_chunk(self, run: Run) -> Optional[Ending]:
        vmax = self.speed()
        if vmax > self.limit:
            return Ending("unstable", f"soil speed {vmax:.3g} m/s exceeds the guard {self.limit:.3g} m/s at "
                                      f"t = {run.time_s:.4g} s; lower solver.cfl (now {self.cfl}) or raise "
                                      f"solver.hourglass (now {self.hourglass})")
        return None


@dataclass
class TopOfDomain(Tracker):
    """Soil that bears in the top row of cells: out of the domain, whose closed top would hold its heave.

    Soil bears once a cell holds more than ``bearing_fill`` of it (``solver.stress_cutoff``); lighter
    traces carry no stress and the closed top holds them harmlessly. The remap carries such traces up
    the void as the grid follows a body down: the vehicle pitched 4° at touchdown had 1e-6 to 3e-6 of
    a cell in each cell of a column between its tracks, from its soil's surface six rows up to the top,
    at 0.17 s, while the soil it heaved stood four rows below the top."""

    top_fill: Callable[[], float]
    travel: float
    bearing_fill: float

    def after_chunk(self, run: Run) -> Optional[Ending]:
        if self.top_fill() > self.bearing_fill:
            return Ending("out_of_domain", f"soil reached the top of the domain at sinkage {run.sinkage_m:.4g} m; "
                                           f"raise solver.initial_travel_m (sized for {self.travel:.3g} m)")
        return None


@dataclass
class Rest(Tracker):
    """A landing ends when the body first comes to rest, or (economy off) at twice that time. A body
    that neither moves nor weighs anything stays at rest.

    A body is at rest only once the soil bears it: the soil's mean force on it over the last chunk at
    least ``borne_n`` (per track): a body thrown up by its touchdown stops for an instant at the top of the
    bounce, borne by less than its weight, and falls again. A body free to turn (``turns``: the slots of
    its free turns' reactions) is at rest only once the soil's moment on it about its centre of gravity,
    where its weight acts, has fallen below ``moment_limit_n_m``: a vehicle rocking onto one track stops
    for an instant at the end of each rock, its weight's moment about that track still turning it."""

    weightless: bool
    stop_at_rest: bool
    turns: tuple[int, ...] = ()
    moment_limit_n_m: float = 0.0
    borne_n: float = -math.inf
    rest_time_s: Optional[float] = None

    def after_chunk(self, run: Run) -> Optional[Ending]:
        if run.code == RUNNING and abs(run.body[B_VEL]) < 1e-12 and self.weightless:
            return Ending("ok", "the body neither moves nor weighs anything: it stays at rest")
        if run.code == AT_REST and self.rest_time_s is None and (run.force_n < self.borne_n or any(
                abs(run.mean_reaction(slot)) > self.moment_limit_n_m for slot in self.turns)):
            run.code = RUNNING  # an instant's stop of a body not yet borne, or still turning
            return None
        if run.code == AT_REST and self.rest_time_s is None:
            self.rest_time_s = run.time_s
            run.message = f"came to rest at {run.max_sinkage_m:.4g} m after {self.rest_time_s:.4g} s"
        if self.rest_time_s is not None:
            if self.stop_at_rest or run.time_s >= 2.0 * self.rest_time_s:
                return Ending("ok", run.message)
            run.code = RUNNING  # economy off: run on past rest (the max sinkage is already known)
        return None


@dataclass
class BearingFailure(Tracker):
    """A body must slow down within ``width`` of sinkage (one width B, or the travel the domain
    was sized for when the soil may stop it later): else the soil cannot stop it."""

    width: float
    width_is_b: bool

    def after_chunk(self, run: Run) -> Optional[Ending]:
        s = np.asarray(run.history["sinkage_m"])
        if s[-1] <= self.width:
            return None
        v = np.asarray(run.history["velocity_m_s"])
        if v[-1] >= np.interp(s[-1] - self.width, s, v):  # no slower than one width ago
            what = "one width B" if self.width_is_b else "the travel the domain was sized for"
            return Ending("bearing_failure", f"the body kept sinking without slowing down over {self.width:g} m "
                                             f"({what})")
        return None


#: a slide that slowed by less than this share of its fastest speed over its last width B would, slowing
#: on at that rate (Δv per B), need B·v/(2·Δv) ≥ 10 more widths to stop: :class:`SlideFailure` ends it
SLIDE_SLOWING_SHARE = 0.05


@dataclass
class SlideFailure(Tracker):
    """A landing free to slide (down a slope, or drifting) must slow its slide within ``width`` of sliding:
    a body that slid one width B and has slowed by less than :data:`SLIDE_SLOWING_SHARE` from its fastest
    over the last width cannot be held by the soil, as one that sinks a width without slowing
    (:class:`BearingFailure`). Against the fastest over the last width, not the speed a width ago: a slide
    set off from rest speeds up first, and the vehicle set down on a slope 18 % past its envelope, slowing
    from 0.42 to 0.17 m/s, was ended after a width as sliding "without slowing down" by the speed it had a
    width before, nearly 0. With a share, not strictly as fast: the 30 t vehicle on 45° on B/16 slid on at
    a steady 0.678 m/s past its width, its speed a hair under its fastest, and was not ended. The slide and
    its speed are the body's own (displacement and velocity along x and y), kept chunk by chunk."""

    width: float
    slides: list = field(default_factory=list)
    speeds: list = field(default_factory=list)

    def after_chunk(self, run: Run) -> Optional[Ending]:
        body = run.body
        slide = math.hypot(body[B_OFFSET_X], body[B_OFFSET_Y])
        speed = math.hypot(body[B_VX], body[B_VY])
        self.slides.append(slide)
        self.speeds.append(speed)
        if slide <= self.width:
            return None
        reach = np.maximum.accumulate(self.slides)
        fastest = max(self.speeds[int(np.searchsorted(reach, slide - self.width)):])  # over the last width
        if speed >= (1.0 - SLIDE_SLOWING_SHARE) * fastest:
            return Ending("bearing_failure", f"the body slid {slide:.3g} m and slowed by less than "
                                             f"{SLIDE_SLOWING_SHARE:.0%} over the last {self.width:g} m (one width B): "
                                             "the soil cannot hold it")
        return None


@dataclass
class PushEnd(Tracker):
    """A push ends at its displacement (m, of the translations it drives: ``pose_slots``, the body's
    slots of their displacements) or its rotation (degrees, when it drives one)."""

    displacement: Optional[float]
    pose_slots: tuple = (B_OFFSET,)
    rotation_deg: Optional[float] = None

    def after_chunk(self, run: Run) -> Optional[Ending]:
        if self.displacement is not None and self.pose_slots:
            travelled = math.sqrt(sum(float(run.body[s]) ** 2 for s in self.pose_slots))
            if travelled >= self.displacement - 1e-12:
                turned = f", turned {run.turned_deg:.4g}°" if self.rotation_deg is not None else ""
                where = f"to {run.sinkage_m:.4g} m" if self.pose_slots == (B_OFFSET,) else f"{travelled:.4g} m"
                return Ending("ok", f"pushed {where}{turned}")
        if self.rotation_deg is not None and run.turned_deg >= self.rotation_deg - 1e-12:
            return Ending("ok", f"turned to {run.turned_deg:.4g}° at {run.sinkage_m:.4g} m")
        return None


@dataclass
class Cycles(Tracker):
    """A cyclic push: down to ``displacement``, then ``cycles`` times up ``stroke`` and back down (m); the
    prescribed speed turns between chunks, once the stroke's end is reached (a chunk's travel past it)."""

    displacement: float
    stroke: float
    cycles: int
    going_up: bool = False
    done: int = 0

    def after_chunk(self, run: Run) -> Optional[Ending]:
        travel = run.travel_m
        if not self.going_up and travel >= self.displacement - 1e-12:
            if self.done == self.cycles:
                return Ending("ok", f"pushed {self.cycles} cycles of {self.stroke:.4g} m to {run.sinkage_m:.4g} m")
            self.going_up = True
            run.body[B_VEL] = abs(run.body[B_VEL])      # up: z up +
        elif self.going_up and travel <= self.displacement - self.stroke + 1e-12:
            self.going_up = False
            self.done += 1
            run.body[B_VEL] = -abs(run.body[B_VEL])
        return None


@dataclass
class TravelLimit(Tracker):
    """A landing past the travel the domain was sized for: out of the domain."""

    travel: float

    def after_chunk(self, run: Run) -> Optional[Ending]:
        if run.travel_m > self.travel:
            return Ending("out_of_domain", f"the body passed the travel the domain was sized for ({self.travel:.3g} m); "
                                           f"raise solver.initial_travel_m")
        return None


@dataclass
class MotionLimit(Tracker):
    """Small strain (no remap): the undeformed grid does not follow the body, so a slide or a turn that
    carries its edge past the uniform cells around it (``margin_m``; ``reach_m`` the lever of a turn)
    is out of the domain."""

    margin_m: float
    reach_m: float

    def after_chunk(self, run: Run) -> Optional[Ending]:
        slide = float(run.body[B_MAXSLIDE])
        edge = math.sin(min(float(run.body[B_MAXROT]), 0.5 * math.pi)) * self.reach_m
        if max(slide, edge) > self.margin_m:
            moved = f"slid {slide:.3g} m" if slide >= edge else f"turned its edge {edge:.3g} m"
            return Ending("out_of_domain", f"the body {moved} on the undeformed grid (small strain), past the "
                                           f"{self.margin_m:.3g} m of uniform cells around it; widen "
                                           f"solver.core_margin_widths or run with the remap")
        return None


@dataclass
class StepBudget(Tracker):
    """solver.max_steps spent: no result."""

    max_steps: int

    def after_chunk(self, run: Run) -> Optional[Ending]:
        if run.steps >= self.max_steps:
            return Ending("unstable", f"no result after solver.max_steps = {self.max_steps} steps")
        return None
