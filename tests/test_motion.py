import math

import numpy as np
import pytest

from transplanter.machine import motion, steppers
from transplanter.machine.kinematics import fivebar as kin

GEOM = kin.FiveBarGeometry()
LIMITS = kin.KinematicLimits()
DRIVES = steppers.default_drives()
KIN = kin.FiveBarKinematics(geometry=GEOM, limits=LIMITS, mode="+-", drives=DRIVES)
CONFIG = motion.MotionConfig()


def steps_of(xyz, drives=DRIVES):
    t1, t2 = kin.ik(GEOM, xyz[0], xyz[1])
    return np.array(
        [drives[0].to_steps(t1), drives[1].to_steps(t2), drives[2].to_steps(xyz[2])],
        dtype=np.int64,
    )


def random_targets(n, seed):
    rng = np.random.default_rng(seed)
    return np.column_stack(
        [rng.uniform(-0.1, 0.1, n), rng.uniform(0.12, 0.24, n), rng.uniform(0.01, 0.15, n)]
    )


def _reference_bresenham(a, b):
    """The classic error-accumulator loop, one point at a time."""
    a, b = list(a), list(b)
    delta = [abs(b[i] - a[i]) for i in range(3)]
    sign = [1 if b[i] >= a[i] else -1 for i in range(3)]
    major = max(range(3), key=lambda i: (delta[i], -i))
    others = [i for i in range(3) if i != major]
    d = delta[major]
    err = {i: 2 * delta[i] - d for i in others}
    point = list(a)
    out = [tuple(point)]
    for _ in range(d):
        point[major] += sign[major]
        for i in others:
            if err[i] >= 0:
                point[i] += sign[i]
                err[i] -= 2 * d
            err[i] += 2 * delta[i]
        out.append(tuple(point))
    return np.array(out, dtype=np.int64)


def test_bresenham_matches_classic_loop():
    rng = np.random.default_rng(0)
    for _ in range(300):
        a = rng.integers(-40, 40, 3)
        b = rng.integers(-40, 40, 3)
        got = motion.bresenham_3d(a, b)
        np.testing.assert_array_equal(got, _reference_bresenham(a, b))
        assert got.dtype == np.int64
        np.testing.assert_array_equal(got[0], a)
        np.testing.assert_array_equal(got[-1], b)
        steps = np.abs(np.diff(got, axis=0))
        assert steps.max(initial=0) <= 1
        major = int(np.argmax(np.abs(b - a)))
        assert np.all(steps[:, major] == 1)


def test_bresenham_degenerate_and_bad_input():
    np.testing.assert_array_equal(motion.bresenham_3d([1, 2, 3], [1, 2, 3]), [[1, 2, 3]])
    np.testing.assert_array_equal(motion.bresenham_3d([0, 0, 0], [3, 0, 0])[:, 0], [0, 1, 2, 3])
    with pytest.raises(ValueError, match="3 integers"):
        motion.bresenham_3d([0.5, 0, 0], [1, 1, 1])
    with pytest.raises(ValueError, match="3 integers"):
        motion.bresenham_3d([0, 0], [1, 1])


def test_config_validation():
    with pytest.raises(ValueError, match="profile"):
        motion.MotionConfig(profile="bang")
    with pytest.raises(ValueError, match="resolution_m"):
        motion.MotionConfig(resolution_m=0.0)
    with pytest.raises(ValueError, match="min_speed_m_s"):
        motion.MotionConfig(min_speed_m_s=-1.0)


def _line_distance(points, a, b):
    direction = (b - a) / np.linalg.norm(b - a)
    rel = points - a
    return np.linalg.norm(rel - np.outer(rel @ direction, direction), axis=1)


def _check_move(move, speed, config, start_steps):
    """Invariants every planned move must satisfy."""
    res = config.resolution_m
    n_points = move.points_xyz.shape[0]
    # steps: accumulated pulses land exactly on the IK of the target
    for m in range(3):
        assert (
            move.start_steps[m] + int(move.step_dirs[m].astype(np.int64).sum())
            == (move.end_steps[m])
        )
        times = move.step_times[m]
        assert times.size == move.step_dirs[m].size
        if times.size:
            assert np.all(np.diff(times) >= 0.0)
            assert times[0] > 0.0 and times[-1] <= move.duration_s
            # no motor faster than its top step rate
            if times.size > 1:
                min_gap = np.diff(times).min()
                assert min_gap >= 1.0 / DRIVES[m].max_step_rate_hz * (1 - 1e-9)
    np.testing.assert_array_equal(move.start_steps, start_steps)
    np.testing.assert_array_equal(move.end_steps, steps_of(move.end_xyz))
    # counters at every point time equal the point's absolute target steps
    at_points = move.steps_at(move.point_times_s)
    np.testing.assert_array_equal(at_points[1:], move.point_steps[1:])
    if n_points < 2 or np.array_equal(move.start_xyz, move.end_xyz):
        return
    # geometry: points lie within sqrt(3) resolution of the ideal line
    dist = _line_distance(move.points_xyz, move.start_xyz, move.end_xyz)
    assert dist.max() <= math.sqrt(3) * res
    # Z follows the exact line height: its steps never bunch at grid steps
    z_line = move.start_xyz[2] + move.path_m / move.path_m[-1] * (
        move.end_xyz[2] - move.start_xyz[2]
    )
    np.testing.assert_allclose(move.points_xyz[:, 2], z_line, atol=1e-12)
    # timing: speed along the straight line, acceleration, point rate
    seg = np.diff(move.path_m)
    dt = np.diff(move.point_times_s)
    assert np.all(dt > 0)
    seg_speed = seg / dt
    assert seg_speed.max() <= speed + 1e-9
    assert seg_speed.max() <= move.peak_speed_m_s * (1 + 1e-9)
    if n_points > 2:
        # The segment speed is the mean of v(t) over the segment; for any v(t) with
        # |dv/dt| <= a the means of two adjacent intervals differ by at most
        # a * (dt_k + dt_k+1) / 2, so only float rounding needs a tolerance.
        accel = np.diff(seg_speed) / (0.5 * (dt[1:] + dt[:-1]))
        assert np.abs(accel).max() <= config.accel_m_s2 * (1 + 1e-6) + 1e-9
    assert dt.min() >= config.compute_time_per_point_s * (1 - 1e-9)
    assert n_points / move.duration_s <= 1.0 / config.compute_time_per_point_s


def test_chained_random_moves_never_drift_and_respect_limits():
    targets = random_targets(1001, seed=1)
    speeds = np.random.default_rng(2).uniform(0.01, 0.3, 1000)
    position = targets[0]
    counters = steps_of(position)
    for i in range(1000):
        config = CONFIG if i % 2 else motion.MotionConfig(profile="scurve")
        move = motion.plan_line(counters, position, targets[i + 1], speeds[i], KIN, config)
        if i % 20 == 0:
            _check_move(move, speeds[i], config, counters)
        counters = move.start_steps + np.array(
            [int(d.astype(np.int64).sum()) for d in move.step_dirs]
        )
        position = targets[i + 1]
        np.testing.assert_array_equal(counters, steps_of(position))
    np.testing.assert_array_equal(counters, steps_of(targets[-1]))


def test_every_move_invariants_on_a_sample():
    targets = random_targets(41, seed=3)
    for i in range(40):
        start, end = targets[i], targets[i + 1]
        counters = steps_of(start)
        for config in (CONFIG, motion.MotionConfig(profile="scurve", resolution_m=5e-4)):
            move = motion.plan_line(counters, start, end, 0.15, KIN, config)
            _check_move(move, 0.15, config, counters)


def test_fk_of_quantised_joints_stays_near_the_line():
    targets = random_targets(21, seed=4)
    half_arm = 0.5 * DRIVES[0].unit_per_step
    half_z = 0.5 * DRIVES[2].unit_per_step
    res = CONFIG.resolution_m
    for i in range(20):
        start, end = targets[i], targets[i + 1]
        move = motion.plan_line(steps_of(start), start, end, 0.1, KIN, CONFIG)
        t1 = DRIVES[0].to_position(move.point_steps[:, 0])
        t2 = DRIVES[1].to_position(move.point_steps[:, 1])
        z = DRIVES[2].to_position(move.point_steps[:, 2])
        x, y = kin.fk(GEOM, t1, t2, "up")
        dist = _line_distance(np.column_stack([x, y, z]), start, end)
        # quantisation error: |J dtheta| with |dtheta| <= sqrt(2) half steps, plus Z half step
        jac = kin.jacobian(GEOM, t1, t2, x, y)
        jac_norm = np.linalg.norm(jac, ord=2, axis=(1, 2))
        bound = math.sqrt(3) * res + jac_norm * math.sqrt(2) * half_arm * 1.01 + half_z
        assert np.all(dist <= bound)
        assert dist.max() > 0  # the quantisation is really there


def test_speed_caps():
    start = np.array([-0.05, 0.15, 0.05])
    end = np.array([0.05, 0.15, 0.05])
    counters = steps_of(start)
    # commanded speed rules when it is low
    slow = motion.plan_line(counters, start, end, 0.05, KIN, CONFIG)
    assert slow.peak_speed_m_s == pytest.approx(0.05)
    assert slow.speed_limit == "" and slow.cruise_speed_m_s == 0.05
    # the point-rate cap: resolution / compute time (Arduino Mega: 0.1 mm / 4027 us)
    mega = motion.MotionConfig(compute_time_per_point_s=4027e-6)
    capped = motion.plan_line(counters, start, end, 1.0, KIN, mega)
    assert capped.peak_speed_m_s == pytest.approx(1e-4 / 4027e-6)
    _check_move(capped, 1.0, mega, counters)
    # every cap says why the move is slower than asked
    assert capped.speed_limit.startswith("the kinematics take 4027 us per 0.1 mm point")
    assert capped.cruise_speed_m_s == pytest.approx(1e-4 / 4027e-6)
    # the step-rate cap: a slow Z motor limits a vertical move
    slow_z = (DRIVES[0], DRIVES[1], steppers.z_drive(max_step_rate_hz=4000.0))
    up = np.array([-0.05, 0.15, 0.09])
    slow_kin = kin.FiveBarKinematics(GEOM, LIMITS, drives=slow_z)
    move = motion.plan_line(counters, start, up, 1.0, slow_kin, CONFIG)
    assert move.peak_speed_m_s == pytest.approx(4000.0 / 400_000.0)  # 10 mm/s
    assert move.speed_limit.startswith("motor 3 reaches its top step rate, 4000 steps/s")
    assert np.diff(move.step_times[2]).min() >= 1 / 4000.0 * (1 - 1e-9)


def test_trapezoid_duration_and_triangular_short_move():
    start = np.array([-0.05, 0.18, 0.05])
    end = start + np.array([0.1, 0.0, 0.0])
    move = motion.plan_line(steps_of(start), start, end, 0.1, KIN, CONFIG)
    v0, v, a = CONFIG.min_speed_m_s, 0.1, CONFIG.accel_m_s2
    ramp_t, ramp_s = (v - v0) / a, (v * v - v0 * v0) / (2 * a)
    length = np.linalg.norm(np.diff(move.points_xyz, axis=0), axis=1).sum()
    assert move.duration_s == pytest.approx(2 * ramp_t + (length - 2 * ramp_s) / v, rel=1e-12)
    assert length == pytest.approx(0.1, abs=1e-12)  # straight along x: no staircase
    short_end = start + np.array([0.001, 0.0, 0.0])
    short = motion.plan_line(steps_of(start), start, short_end, 0.1, KIN, CONFIG)
    assert short.peak_speed_m_s == pytest.approx(math.sqrt(v0 * v0 + a * 0.001))
    assert short.duration_s == pytest.approx(2 * (short.peak_speed_m_s - v0) / a, rel=1e-9)


def test_scurve_starts_gently_and_takes_longer():
    start = np.array([-0.05, 0.18, 0.05])
    end = start + np.array([0.1, 0.0, 0.0])
    trap = motion.plan_line(steps_of(start), start, end, 0.1, KIN, CONFIG)
    scurve_cfg = motion.MotionConfig(profile="scurve")
    scurve = motion.plan_line(steps_of(start), start, end, 0.1, KIN, scurve_cfg)
    # each S ramp lasts 1.5x the trapezoid ramp and covers 1.5x the distance
    ramp_t = (0.1 - 0.002) / 2.0
    # 3T + (L - 3D)/v - (2T + (L - 2D)/v) = T - D/v with D = T (v0 + v) / 2
    extra = ramp_t * (0.1 - 0.002) / (2 * 0.1)
    assert scurve.duration_s - trap.duration_s == pytest.approx(extra, rel=1e-9)

    # acceleration at the very start is near zero for the S-curve, full for the trapezoid
    def first_accel(move):
        # mean acceleration from the start speed up to the first segment's mean speed
        seg = np.linalg.norm(move.points_xyz[1] - move.points_xyz[0])
        dt = move.point_times_s[1]
        return (seg / dt - CONFIG.min_speed_m_s) / (0.5 * dt)

    # smoothstep ramp: mean speed over [0, t] is v0 + dv (u^2 - u^3 / 2), u = t / T
    dv = 0.1 - 0.002
    ramp = 1.5 * dv / 2.0
    u = scurve.point_times_s[1] / ramp
    expected = dv * (u * u - 0.5 * u**3) / (0.5 * scurve.point_times_s[1])
    assert first_accel(scurve) == pytest.approx(expected, rel=1e-9)
    assert first_accel(scurve) < 0.3 * CONFIG.accel_m_s2


def test_unreachable_point_on_the_way_raises_and_plans_nothing():
    start = np.array([-0.09, 0.13, 0.05])
    end = np.array([0.26, 0.13, 0.05])  # beyond reach
    with pytest.raises(kin.UnreachableError) as info:
        motion.plan_line(steps_of(start), start, end, 0.1, KIN, CONFIG)
    assert info.value.index > 0
    assert "not reachable" in str(info.value) and " mm" in str(info.value)


def test_reachable_ends_with_unreachable_middle_raise():
    # both ends fine, but on the way arm 1 would swing past its 235 deg limit
    start = np.array([-0.15, 0.10, 0.05])
    end = np.array([-0.05, 0.10, 0.12])
    ends = kin.check_points(GEOM, LIMITS, [start[0], end[0]], [start[1], end[1]])
    assert ends.ok.all()
    with pytest.raises(kin.UnreachableError) as info:
        motion.plan_line(steps_of(start), start, end, 0.1, KIN, CONFIG)
    err = info.value
    grid = motion.bresenham_3d(
        np.rint(start / CONFIG.resolution_m).astype(np.int64),
        np.rint(end / CONFIG.resolution_m).astype(np.int64),
    )
    bad = grid[err.index] * CONFIG.resolution_m * 1e3
    assert 0 < err.index < grid.shape[0] - 1
    assert err.reason.startswith("motor 1 angle 235.")
    assert f"point {err.index} of {grid.shape[0]} at " in str(err)
    assert f"({bad[0]:.3f}, {bad[1]:.3f}, " in str(err)  # Z is the exact line height
    # the previous grid point was fine: the first bad one is reported
    before = grid[err.index - 1] * CONFIG.resolution_m
    assert kin.check_points(GEOM, LIMITS, before[0], before[1]).ok[0]


def test_zero_length_move():
    here = np.array([0.0, 0.2, 0.05])
    move = motion.plan_line(steps_of(here), here, here, 0.1, KIN, CONFIG)
    assert move.duration_s == 0.0 and move.num_steps == 0
    np.testing.assert_array_equal(move.end_steps, steps_of(here))
    np.testing.assert_array_equal(move.steps_at([0.0, 1.0]), [steps_of(here)] * 2)


def test_counters_off_target_are_caught_up():
    # after homing the counters may not match the IK of the commanded start
    here = np.array([0.0, 0.2, 0.05])
    off = steps_of(here) + np.array([30, -12, 400])
    move = motion.plan_line(off, here, here, 0.1, KIN, CONFIG)
    np.testing.assert_array_equal(move.end_steps, steps_of(here))
    assert move.duration_s == pytest.approx(400 / 20000.0)
    _check_move(move, 0.1, CONFIG, off)
    # in a real move the catch-up is part of the first segment
    end = np.array([0.05, 0.2, 0.05])
    move = motion.plan_line(off, here, end, 0.1, KIN, CONFIG)
    _check_move(move, 0.1, CONFIG, off)


def test_sub_resolution_move():
    start = np.array([0.0, 0.2, 0.05])
    end = start + np.array([2e-5, 0.0, 0.0])
    move = motion.plan_line(steps_of(start), start, end, 0.1, KIN, CONFIG)
    assert move.points_xyz.shape == (2, 3)
    np.testing.assert_array_equal(move.end_steps, steps_of(end))
    assert move.duration_s > 0


def test_bad_arguments():
    here = np.array([0.0, 0.2, 0.05])
    counters = steps_of(here)
    with pytest.raises(ValueError, match="speed_m_s"):
        motion.plan_line(counters, here, here, 0.0, KIN, CONFIG)
    with pytest.raises(ValueError, match="end_xyz"):
        motion.plan_line(counters, here, [0.0, np.nan, 0.0], 0.1, KIN, CONFIG)
    with pytest.raises(ValueError, match="start_steps"):
        motion.plan_line([1.5, 0, 0], here, here, 0.1, KIN, CONFIG)
    with pytest.raises(ValueError, match="Z drive"):
        bad = (DRIVES[0], DRIVES[1], DRIVES[0])
        kin.FiveBarKinematics(geometry=GEOM, limits=LIMITS, drives=bad)
    with pytest.raises(ValueError, match="kinematics"):
        motion.plan_line(counters, here, here, 0.1, (GEOM, LIMITS, DRIVES), CONFIG)


def test_deterministic():
    start, end = random_targets(2, seed=9)
    a = motion.plan_line(steps_of(start), start, end, 0.1, KIN, CONFIG)
    b = motion.plan_line(steps_of(start), start, end, 0.1, KIN, CONFIG)
    for m in range(3):
        assert a.step_times[m].tobytes() == b.step_times[m].tobytes()


def test_move_steps_at_agrees_with_steppers_steps_at():
    start, end = random_targets(2, seed=11)
    move = motion.plan_line(steps_of(start), start, end, 0.1, KIN, CONFIG)
    times = np.concatenate(
        [np.random.default_rng(12).uniform(-0.1, move.duration_s + 0.1, 500), move.step_times[0]]
    )
    got = move.steps_at(times)
    assert got.shape == (times.size, 3) and got.dtype == np.int64
    for m in range(3):
        expected = steppers.steps_at(
            times, move.step_times[m], move.step_dirs[m], move.start_steps[m]
        )
        np.testing.assert_array_equal(got[:, m], expected)
    np.testing.assert_array_equal(move.steps_at(-1.0)[0], move.start_steps)
    np.testing.assert_array_equal(move.steps_at(move.duration_s)[0], move.end_steps)


def test_compute_time_per_point_holds_even_at_extreme_acceleration():
    # a fast start speed would cross the short first (half-cell) segment in 100 us < 198 us
    hasty = motion.MotionConfig(accel_m_s2=1000.0, min_speed_m_s=0.5)
    # off-grid ends 0.45 cells inside the grid end points: 0.55-cell end segments
    start = np.array([-0.05 + 0.45e-4, 0.18, 0.05])
    end = np.array([0.05 - 0.45e-4, 0.18, 0.05])
    counters = steps_of(start)
    move = motion.plan_line(counters, start, end, 1.0, KIN, hasty)
    dt = np.diff(move.point_times_s)
    assert dt.min() >= hasty.compute_time_per_point_s * (1 - 1e-12)
    seg = np.linalg.norm(np.diff(move.points_xyz, axis=0), axis=1)
    assert seg[0] < 0.6 * hasty.resolution_m  # the case the stretch is there for
    assert seg[-1] < 0.6 * hasty.resolution_m
    np.testing.assert_array_equal(move.end_steps, steps_of(end))
    assert (seg / dt).max() <= hasty.point_rate_speed_cap_m_s * (1 + 1e-9)


def test_diagonal_descent_is_not_capped_by_z_step_bunching():
    """Drop point to approach point: 102 mm with 28 mm of Z. The Z motor (400 steps/mm, 20 kHz)
    averages 110 steps per mm of path, so 150 mm/s needs 16.5 kHz: reachable, if its steps
    are spread along the line rather than bunched at each 0.1 mm grid step."""
    start, end = np.array([0.0, 0.140, 0.060]), np.array([-0.090, 0.180, 0.032])
    move = motion.plan_line(
        steps_of(start),
        start,
        end,
        0.150,
        KIN,
        motion.MotionConfig(accel_m_s2=1.5),
    )
    assert move.peak_speed_m_s == pytest.approx(0.150)
    gaps = np.diff(move.step_times[2])
    assert gaps.min() >= 1 / DRIVES[2].max_step_rate_hz * (1 - 1e-9)
    length = float(np.linalg.norm(end - start))
    assert move.duration_s == pytest.approx(length / 0.150 + 0.150 / 1.5, rel=0.02)
