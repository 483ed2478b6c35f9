"""The simulation loop: step events drive the motors, homing uses the model's switches."""

import numpy as np
import pytest

from conftest import paper_config
from transplanter.machine.pgf import LinePhase
from transplanter.twin.sim import LineEventKind, SimulationInvalid, Twin


@pytest.fixture(scope="module")
def scenario():
    return paper_config(1)


def test_motor_fields_are_the_step_positions(scenario):
    """At every physics step each stepper's field stands exactly where its pulses have got by
    the step's start (the torque over the step comes from there), and after the step the
    field the rotor is compared with is where the pulses have got by then."""
    twin = Twin(scenario)
    seen = []

    def check(tw, i):
        now = tw.sgf.pulses_at(np.array([tw.time]))[0]
        expected = tw.q_power_on + now * tw.unit_per_step
        np.testing.assert_allclose(tw.commanded_joints(), expected, rtol=0, atol=1e-12)
        start = tw.sgf.pulses_at(np.array([tw.time - tw.dt]))[0]
        np.testing.assert_array_equal(tw.block.pulses[i], start)
        seen.append(start.copy())

    twin.step_until(6.0, monitor=check, monitor_every=7)
    seen = np.array(seen)
    assert len(seen) > 800
    # the fields move in whole microsteps: every change is a multiple of one step
    assert np.issubdtype(seen.dtype, np.integer)
    assert np.abs(np.diff(seen[:, 2])).max() > 0  # Z has moved


def test_homing_uses_the_model_limit_switches(scenario):
    twin = Twin(scenario)
    twin.step_until(2.0)
    home = next(s for s in twin.pgf.sent if s.phase == LinePhase.HOME)
    assert home.reply == "ok"
    assert twin.sgf.homed
    # at the trip, each joint (as simulated) had reached its switch: the SGF's logical
    # position after the pull-off is the home position minus the pull-off
    cfg = twin.machine.sgf
    logical = twin.sgf.logical_steps
    expected_home = np.asarray(cfg.home_steps)
    assert np.all(np.abs(logical - expected_home) <= np.asarray(cfg.homing.pulloff_steps) + 2)


def test_moves_wait_for_the_handshake(scenario):
    twin = Twin(scenario)
    events = []
    twin.line_listeners.append(lambda e: events.append((e.kind, e.line.text, e.t)))
    twin.step_until(8.0)
    sent = twin.pgf.sent
    assert len(sent) >= 15  # homing, the first move and most of the first cycle
    for before, after in zip(sent[:-1], sent[1:], strict=True):
        assert before.t_reply is not None and after.t_sent >= before.t_reply
    # every line is announced when sent and when its reply arrives, in that order
    kinds = [k for k, _, _ in events]
    assert kinds.count(LineEventKind.SENT) == len(sent)
    assert kinds.count(LineEventKind.DONE) == sum(s.reply is not None for s in sent)
    first_sent = {text: t for k, text, t in events if k == LineEventKind.SENT}
    for k, text, t in events:
        if k == LineEventKind.DONE:
            assert t >= first_sent[text]


def test_bad_physics_is_an_error_not_a_result(scenario):
    """A diverging simulation (here an infinite force injected at 3 s) raises
    SimulationInvalid; trials turn it into an invalid result (tested in test_trial)."""

    def poison(tw):
        if tw.time > 3.0:
            tw.data.qfrc_applied[:] = np.inf

    twin = Twin(scenario)
    twin.exchange_listeners.append(poison)
    with pytest.raises(SimulationInvalid, match="MuJoCo warning|diverged"):
        twin.step_until(5.0)
    assert 3.0 < twin.time < 5.0


def test_overloaded_motor_loses_steps_for_good():
    """A Z motor driven past its pull-out torque slips: with its corner at 2 rev/s, Z's moves
    at 150 mm/s (18.75 rev/s) have 0.048 N m where the slide needs about 0.05 (weight and
    screw friction); the steps it loses stay lost (the firmware's position and the
    platform's differ by them once the motor is at rest)."""
    weak = paper_config(
        1,
        **{
            "drives.pullout_corner_rev_s": 2.0,
            "drives.max_step_rate_hz": 80000.0,
            "taught.s_low_mm_s": 150.0,
        },
    )
    twin = Twin(weak)
    while not twin.sgf.homed:  # homing re-references whatever slipped on the way up
        twin.step_until(twin.time + 0.1)
    lost_at_homing = twin.microsteps_lost.copy()
    twin.step_until(twin.time + 4.6)  # through the lift, into the retract at Z_up
    lost = twin.microsteps_lost - lost_at_homing
    assert lost[2] >= 5 * 64  # five electrical cycles or more: 0.8 mm
    assert not lost[:2].any()
    # the firmware believes it is at Z_up; the platform is off by the lost steps (within
    # the rotor's lag and the homing reference error, a few full steps)
    z_firmware = twin.sgf.position_xyz[2]
    z_platform = twin.scene.joint_positions(twin.data)[2]
    gap = z_firmware - z_platform
    assert gap == pytest.approx(lost[2] * twin.unit_per_step[2], abs=3 * twin.full_step_joint[2])


def test_normal_motors_lose_no_steps(scenario):
    twin = Twin(scenario)
    twin.step_until(9.0)
    assert not twin.microsteps_lost.any()


def test_conveyor_index_ends_at_one_pitch_and_at_rest():
    """After the row's last pickup the PGF sends M710: the conveyor moves one row pitch, its
    drive force is released by the time the SGF acknowledges, and the pots come to rest."""
    five = paper_config(6)
    twin = Twin(five)
    for _ in range(1000):  # the index is acknowledged near 21 s
        if any(s.phase == LinePhase.INDEX and s.reply for s in twin.pgf.sent):
            break
        twin.step_until(twin.time + 0.05)
    twin.step_until(twin.time + 0.1)  # the next approach is under way, far from the pots
    index = next(s for s in twin.pgf.sent if s.phase == LinePhase.INDEX)
    assert index.reply == "ok"
    assert index.t_reply - index.t_sent == pytest.approx(0.6, abs=0.01)
    scene, d = twin.scene, twin.data
    pitch = five.scene.row_pitch_m
    assert scene.conveyor_position(d) == pytest.approx(-pitch, abs=0.0005)
    # the emptied row went round the front drum: its ribs no longer touch anything (they
    # would otherwise sweep through the drop tube and jam on the pot dropped last)
    m = twin.model
    ribs = [g for g in range(m.ngeom) if (m.geom(g).name or "").startswith("rib_")]
    row0 = [g for g in ribs if m.geom(g).name.startswith("rib_0_")]
    assert (m.geom_conaffinity[row0] == 0).all()
    assert (m.geom_conaffinity[[g for g in ribs if g not in row0]] != 0).all()
    assert d.qfrc_applied[scene.conveyor_dof_adr] == 0.0
    assert not scene.conveyor_armed(d)
    # the next row stands in the pickup row, upright, every pot in its cell
    pots = scene.pot_positions(d).reshape(scene.pot_bodies.shape + (3,))
    row1 = pots[1]
    assert np.abs(row1[:, 1] - five.scene.pickup_row_y_m).max() < 0.004
    assert np.abs(row1[:, 2] - five.scene.pot_height_m / 2).max() < 0.003


def test_servos_hold_their_power_on_pose_until_commanded(scenario):
    """Before the first M280 the gripper stays fully open and the wrist where it was."""
    twin = Twin(scenario)
    scene, d = twin.scene, twin.data
    opening0 = scene.gripper_opening(d)
    wrist0 = d.qpos[scene.wrist_qpos_adr]
    first_servo = None
    for _ in range(500):  # the first M280 goes out after homing, near 2 s
        if first_servo is not None:
            break
        twin.step_until(twin.time + 0.01)
        first_servo = next(
            (
                s.t_sent
                for s in twin.pgf.sent
                if s.text.split()[1:2] == ["M280"] or s.text.startswith("M280")
            ),
            None,
        )
        assert scene.gripper_opening(d) == pytest.approx(opening0, abs=2e-4)
        assert d.qpos[scene.wrist_qpos_adr] == pytest.approx(wrist0, abs=0.01)  # servo compliance
    assert first_servo is not None
    assert twin.gripper_opening_cmd(np.array([0.0, first_servo]))[0] == pytest.approx(opening0)


class _ExchangeEveryStep(Twin):
    """The twin exchanging with the firmware at every physics step while the SGF homes
    and while nothing is in flight (as it did before it watched the switches itself)."""

    def _next_exchange_time(self, t: float, idle_until: float) -> float:
        t_next = super()._next_exchange_time(t, t + self.dt)
        return min(t_next, t + self.dt) if self.sgf.homing else t_next


def _counting(cls, built: list):
    """A twin factory: `cls` counting its exchanges, each twin it builds kept in `built`."""

    def factory(config):
        twin = cls(config)
        twin.exchanges = 0

        def count(_twin):
            twin.exchanges += 1

        twin.exchange_listeners.append(count)
        built.append(twin)
        return twin

    return factory


def test_exchanging_only_when_the_firmware_needs_it_changes_no_result():
    """Homing exchanges at switch changes and at the homing's own times, and the settle
    after the program in one block: the same trial, bit for bit, with far fewer
    exchanges."""
    from transplanter.twin.trial import run_trial

    config = paper_config(2)
    results, exchanges = [], []
    for cls in (_ExchangeEveryStep, Twin):
        built: list = []
        result = run_trial(config, twin_factory=_counting(cls, built)).to_dict()
        for key in ("wall_time_s", "real_time_factor"):
            result.pop(key)
        results.append(result)
        exchanges.append(built[0].exchanges)
    assert results[0] == results[1]
    assert exchanges[1] < exchanges[0] / 10, exchanges  # 116 against 1626 here
