"""How many steps the next compiled call may take, and when Python must act between calls.

A call aims at ``WALL_SECONDS_PER_CALL`` of wall time (that sets how often progress is
reported), so its length follows the wall clock.  Nothing that changes the run may therefore
happen at an arbitrary call boundary: the stop rule, the snapshots and the landing checks of
detached particles run on schedules of their own (stage time, stage steps), and the calls are
cut to end on them.  A run is then the same on a fast or a slow machine.

- **stop rule**: asked every ``STOP_CHECK_FRACTION`` of the stage's duration (stage time);
- **snapshots**: every snapshot interval of stage time;
- **a periodic action** (e.g. a step of a strength ramp): every action interval of stage time;
- **landing checks**: a detached particle must be seen before it crosses the mesh, so with
  particles outside the mesh a check comes after half a spacing of travel at the largest
  velocity component of any particle (stage steps).
"""

from __future__ import annotations

import math

WALL_SECONDS_PER_CALL = 0.25
"""Target wall time of one compiled call (sets how often progress is reported)."""

STOP_CHECK_FRACTION = 0.02
"""With a stop rule, it is asked every this fraction of the stage's duration (simulated time)."""

FIRST_GUESS_S_PER_PARTICLE_STEP = 1e-7
"""0.1 us per particle-step: the first call's length; later calls adapt to the measured speed."""


def _steps_until(target_s: float, stage_time_s: float, dt_s: float) -> int:
    """Steps that reach stage time ``target_s`` (at least 1)."""
    return max(1, int(math.ceil((target_s - stage_time_s) / dt_s - 1e-9)))


def _due(target_s: float, stage_time_s: float, dt_s: float) -> bool:
    return stage_time_s >= target_s - 0.5 * dt_s


class StageSchedule:
    """The call lengths and the stop / snapshot / landing schedules of one stage (module doc)."""

    def __init__(self, duration_s: float, n_particles: int, stop_rule: bool, snapshot_interval_s: float | None,
                 action_interval_s: float | None = None):
        self.duration_s = duration_s
        self.steps_per_call = max(10, int(WALL_SECONDS_PER_CALL / (FIRST_GUESS_S_PER_PARTICLE_STEP * max(n_particles, 1))))
        self.stop_every_s = STOP_CHECK_FRACTION * duration_s if stop_rule else None
        self.next_stop_s = self.stop_every_s
        self.snapshot_interval_s = snapshot_interval_s
        self.next_snapshot_s = snapshot_interval_s
        self.last_snapshot_s = 0.0
        self.action_interval_s = action_interval_s
        self.next_action_s = action_interval_s
        self.next_landing_step = -1  # stage step of the next landing check (-1: none scheduled)

    def running(self, stage_time_s: float, dt_s: float) -> bool:
        """True until the stage's duration is reached (to half a step)."""
        return stage_time_s < self.duration_s - 0.5 * dt_s

    def next_call_steps(self, stage_time_s: float, dt_s: float, stage_steps: int) -> int:
        """Steps of the next compiled call: the wall-clock target, cut at the end of the stage,
        the next snapshot, the next stop-rule check and the next landing check."""
        n_want = min(self.steps_per_call, max(1, int(round((self.duration_s - stage_time_s) / dt_s))))
        if self.next_snapshot_s is not None:
            n_want = min(n_want, _steps_until(self.next_snapshot_s, stage_time_s, dt_s))
        if self.next_stop_s is not None:
            n_want = min(n_want, _steps_until(self.next_stop_s, stage_time_s, dt_s))
        if self.next_action_s is not None:
            n_want = min(n_want, _steps_until(self.next_action_s, stage_time_s, dt_s))
        if self.next_landing_step >= 0:
            n_want = max(1, min(n_want, self.next_landing_step - stage_steps))
        return n_want

    def adapt(self, steps_done: int, elapsed_s: float) -> None:
        """Aim the next calls at the wall-clock target from the speed just measured."""
        if steps_done >= 10 and elapsed_s > 0:
            self.steps_per_call = max(10, int(steps_done * WALL_SECONDS_PER_CALL / elapsed_s))

    def plan_landing_check(self, has_orphans: bool, stage_steps: int, max_speed_m_s: float, spacing_m: float,
                           dt_s: float) -> None:
        """Schedule a landing check after h/2 of travel at ``max_speed_m_s`` (none without
        detached particles; an already scheduled one is kept)."""
        if not has_orphans:
            self.next_landing_step = -1
        elif self.next_landing_step < 0:
            speed = max(max_speed_m_s, 1e-12)
            self.next_landing_step = stage_steps + max(1, int(0.5 * spacing_m / (speed * dt_s)))

    def landing_check_due(self, stage_steps: int) -> bool:
        """True (once) when the scheduled landing check has come; the next is planned afresh."""
        if 0 <= self.next_landing_step <= stage_steps:
            self.next_landing_step = -1
            return True
        return False

    def stop_check_due(self, stage_time_s: float, dt_s: float) -> bool:
        """True when the stop rule is to be asked now (the next check is then scheduled)."""
        if self.next_stop_s is None or not _due(self.next_stop_s, stage_time_s, dt_s):
            return False
        while self.next_stop_s <= stage_time_s + 0.5 * dt_s:
            self.next_stop_s += self.stop_every_s
        return True

    def snapshot_due(self, stage_time_s: float, dt_s: float) -> bool:
        """True when a snapshot is to be taken now (the next is then scheduled)."""
        if self.next_snapshot_s is None or not _due(self.next_snapshot_s, stage_time_s, dt_s):
            return False
        self.last_snapshot_s = stage_time_s
        while self.next_snapshot_s <= stage_time_s + 0.5 * dt_s:
            self.next_snapshot_s += self.snapshot_interval_s
        return True

    def action_due(self, stage_time_s: float, dt_s: float) -> bool:
        """True when the periodic action is to be taken now (the next is then scheduled)."""
        if self.next_action_s is None or not _due(self.next_action_s, stage_time_s, dt_s):
            return False
        while self.next_action_s <= stage_time_s + 0.5 * dt_s:
            self.next_action_s += self.action_interval_s
        return True

    def final_snapshot_due(self, stage_time_s: float, dt_s: float) -> bool:
        """True when the end of the stage was not a snapshot time already."""
        return self.snapshot_interval_s is not None and stage_time_s > self.last_snapshot_s + 0.5 * dt_s
