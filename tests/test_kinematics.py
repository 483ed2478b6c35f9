import math
import re

import numpy as np
import pytest

from transplanter.machine.kinematics import fivebar as kin

GEOM = kin.FiveBarGeometry()
LIMITS = kin.KinematicLimits()


def workspace_points(n, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-0.1, 0.1, n), rng.uniform(0.12, 0.24, n)


def test_geometry_and_limits_validate():
    with pytest.raises(ValueError, match="l1_m"):
        kin.FiveBarGeometry(l1_m=0.0)
    with pytest.raises(ValueError, match="l0_m"):
        kin.FiveBarGeometry(l0_m=float("nan"))
    with pytest.raises(ValueError, match="motor 1 window"):
        kin.KinematicLimits(motor1_min_rad=2.0, motor1_max_rad=1.0)
    with pytest.raises(ValueError, match="transmission_min_rad"):
        kin.KinematicLimits(transmission_min_rad=2.0, transmission_max_rad=1.0)
    with pytest.raises(ValueError, match="mode"):
        kin.ik(GEOM, 0.0, 0.2, mode="+")
    with pytest.raises(ValueError, match="assembly"):
        kin.fk(GEOM, 1.0, 2.0, assembly="left")


def test_motor2_window_mirrors_motor1_by_default():
    lo, hi = LIMITS.motor_window(2)
    assert lo == pytest.approx(math.pi - LIMITS.motor1_max_rad)
    assert hi == pytest.approx(math.pi - LIMITS.motor1_min_rad)
    custom = kin.KinematicLimits(motor2_min_rad=-1.0, motor2_max_rad=1.5)
    assert custom.motor_window(2) == (-1.0, 1.5)


def test_region_form_equals_general_elbows_out_form():
    x, y = workspace_points(20000, seed=1)
    # include the region boundaries x = +-L0 exactly
    x[:2] = [-GEOM.l0_m, GEOM.l0_m]
    t1r, t2r = kin.ik_region(GEOM, x, y)
    t1, t2 = kin.ik(GEOM, x, y, mode="+-")
    np.testing.assert_allclose(t1r, t1, rtol=0, atol=1e-12)
    np.testing.assert_allclose(t2r, t2, rtol=0, atol=1e-12)
    # all three regions are exercised
    assert (x < -GEOM.l0_m).any() and (x > GEOM.l0_m).any() and (np.abs(x) < GEOM.l0_m).any()


def test_ik_known_point_by_hand():
    # C straight above the origin at 200 mm: symmetric arms, theta2 = pi - theta1
    k = math.hypot(0.05, 0.2)
    gamma = math.acos((0.12**2 - 0.2**2 + k * k) / (2 * 0.12 * k))
    beta1 = math.atan2(0.2, 0.05)
    t1, t2 = kin.ik(GEOM, 0.0, 0.2)
    assert t1 == pytest.approx(beta1 + gamma, abs=1e-15)
    assert t2 == pytest.approx(math.pi - (beta1 + gamma), abs=1e-15)
    assert np.ndim(t1) == 0


def test_ik_then_fk_up_returns_point_on_100k_points():
    x, y = workspace_points(100_000, seed=2)
    t1, t2 = kin.ik(GEOM, x, y)
    xf, yf = kin.fk(GEOM, t1, t2, assembly="up")
    err = np.hypot(xf - x, yf - y)
    assert err.max() < 1e-12


@pytest.mark.parametrize(
    "mode,assembly", [("+-", "up"), ("-+", "down"), ("++", "up"), ("--", "up")]
)
def test_all_modes_close_the_loop(mode, assembly):
    x, y = workspace_points(5000, seed=3)
    t1, t2 = kin.ik(GEOM, x, y, mode=mode)
    assert np.isfinite(t1).all() and np.isfinite(t2).all()
    # both passive links have length L2
    b, d = kin.elbow_points(GEOM, t1, t2)
    np.testing.assert_allclose(np.hypot(x - b[:, 0], y - b[:, 1]), GEOM.l2_m, atol=1e-14)
    np.testing.assert_allclose(np.hypot(x - d[:, 0], y - d[:, 1]), GEOM.l2_m, atol=1e-14)
    assert (kin.assembly_of(GEOM, t1, t2, x, y) == (assembly == "up")).all()
    xf, yf = kin.fk(GEOM, t1, t2, assembly=assembly)
    assert np.hypot(xf - x, yf - y).max() < 1e-12
    other = "down" if assembly == "up" else "up"
    xo, yo = kin.fk(GEOM, t1, t2, assembly=other)
    assert np.hypot(xo - x, yo - y).min() > 1e-3


def test_modes_differ():
    t_pm = np.array(kin.ik(GEOM, 0.03, 0.2, "+-"))
    t_mp = np.array(kin.ik(GEOM, 0.03, 0.2, "-+"))
    assert np.all(np.abs(t_pm - t_mp) > 0.5)


def test_unreachable_gives_nan():
    t1, t2 = kin.ik(GEOM, [0.0, 0.0, 0.5], [0.2, 0.03, 0.5])
    assert np.isfinite(t1[0]) and np.isnan(t1[1]) and np.isnan(t1[2]) and np.isnan(t2[2])
    # elbows 2 L2 + apart: links cannot close
    x, y = kin.fk(GEOM, math.pi, 0.0)
    assert np.isfinite(x)
    xs, ys = kin.fk(kin.FiveBarGeometry(l0_m=0.3, l1_m=0.12, l2_m=0.2), math.pi, 0.0)
    assert np.isnan(xs) and np.isnan(ys)


def test_jacobian_matches_finite_differences():
    x, y = workspace_points(200, seed=4)
    for mode in kin.MODES:
        t1, t2 = kin.ik(GEOM, x, y, mode)
        assembly = "down" if mode == "-+" else "up"
        jac = kin.jacobian(GEOM, t1, t2, x, y)
        assert jac.shape == (200, 2, 2)
        h = 1e-6
        for j, (dt1, dt2) in enumerate(((h, 0.0), (0.0, h))):
            xp, yp = kin.fk(GEOM, t1 + dt1, t2 + dt2, assembly)
            xm, ym = kin.fk(GEOM, t1 - dt1, t2 - dt2, assembly)
            fd = np.stack([(xp - xm) / (2 * h), (yp - ym) / (2 * h)], axis=-1)
            np.testing.assert_allclose(jac[:, :, j], fd, rtol=0, atol=1e-7)


def test_condition_number_matches_numpy():
    x, y = workspace_points(300, seed=5)
    t1, t2 = kin.ik(GEOM, x, y)
    jac = kin.jacobian(GEOM, t1, t2, x, y)
    np.testing.assert_allclose(kin.condition_number(jac), np.linalg.cond(jac), rtol=1e-10)
    assert kin.condition_number(np.zeros((2, 2))) == np.inf


def test_transmission_and_elbow_angles_by_hand():
    # symmetric point: transmission angle = 2 * asin(|BD| / 2 / L2)
    t1, t2 = kin.ik(GEOM, 0.0, 0.2)
    b, d = kin.elbow_points(GEOM, t1, t2)
    expected = 2 * math.asin(np.linalg.norm(d - b) / 2 / GEOM.l2_m)
    assert kin.transmission_angle(GEOM, t1, t2, 0.0, 0.2) == pytest.approx(expected, abs=1e-14)
    # elbow angle by the cosine rule in triangle O1 B C
    k = math.hypot(0.05, 0.2)
    cos_b = (0.12**2 + 0.2**2 - k * k) / (2 * 0.12 * 0.2)
    e1, e2 = kin.elbow_angles(GEOM, t1, t2, 0.0, 0.2)
    assert e1 == pytest.approx(math.acos(cos_b), abs=1e-14)
    assert e2 == pytest.approx(e1, abs=1e-14)


def test_design_workspace_is_reachable_with_default_limits():
    x_mm, y_mm = np.meshgrid(np.linspace(-100, 100, 201), np.linspace(120, 240, 121))
    report = kin.check_points(GEOM, LIMITS, x_mm * 1e-3, y_mm * 1e-3)
    assert report.ok.all(), report.reasons[report.failing[0]]
    # the design numbers (docs/sources.md): passive-link angle 70-116 deg, condition <= 1.7
    assert 70.0 < np.degrees(report.diagnostics["transmission"].min()) < 71.0
    assert 115.0 < np.degrees(report.diagnostics["transmission"].max()) < 116.0
    assert report.diagnostics["condition"].max() < 1.7
    assert report.reasons == ("",) * x_mm.size


def test_rejects_outside_workspace_with_reason():
    report = kin.check_points(GEOM, LIMITS, [0.0, 0.0, 0.0], [0.2, 0.4, 0.03])
    assert report.ok.tolist() == [True, False, False]
    assert report.reasons[0] == ""
    assert "outside workspace: |C-O1|=403.1 mm > L1+L2=320.0 mm" in report.reasons[1]
    assert "outside workspace: |C-O1|=58.3 mm < |L1-L2|=80.0 mm" in report.reasons[2]


def test_rejects_motor_limit_with_reason():
    # reachable by the links, but arm 1 would have to swing to 65 deg (window 80-235 deg)
    report = kin.check_points(GEOM, LIMITS, 0.2, 0.1)
    assert not report.ok[0]
    assert report.reasons[0] == "motor 1 angle 65.3 deg outside [80, 235] deg"
    # motor 2 mirrored
    report = kin.check_points(GEOM, LIMITS, -0.2, 0.1)
    assert report.reasons[0] == "motor 2 angle 114.7 deg outside [-55, 100] deg"
    # an angle just below the lower limit is shown below it, not wrapped by 360 deg
    report = kin.check_points(GEOM, LIMITS, 0.12, 0.1)
    assert report.reasons[0].startswith("motor 2 angle -56.4 deg")


def test_rejects_near_parallel_singularity_with_reason():
    # in the '++' mode the passive links nearly align over part of the workspace
    wide = kin.KinematicLimits(motor2_min_rad=math.radians(100), motor2_max_rad=math.radians(260))
    x, y = workspace_points(2000, seed=6)
    report = kin.check_points(GEOM, wide, x, y, mode="++")
    trans_deg = np.degrees(report.diagnostics["transmission"])
    near = trans_deg < 30.0
    assert near.any() and (~near).any()
    assert not report.ok[near].any()
    for i in np.flatnonzero(near)[:20]:
        match = re.search(
            r"transmission angle (\S+) deg outside \[30, 150\] deg", report.reasons[i]
        )
        assert match, report.reasons[i]
        # the value is shown with enough digits to be visibly below 30 (no "30.0 outside")
        shown = float(match.group(1))
        assert shown < 30.0 and shown == pytest.approx(trans_deg[i], abs=0.05)
        assert "near parallel singularity" in report.reasons[i]


def test_limit_messages_show_enough_digits_to_be_outside():
    """Issue row 16: rounding made 79.96 deg read "80.0 deg outside [80, 235]"."""
    from transplanter.units import show, show_outside

    assert show_outside(79.96, 80, 235) == ("79.96", "80", "235")
    assert show_outside(235.0004, 80, 235) == ("235.0004", "80", "235")
    assert show_outside(65.3, 80, 235) == ("65.3", "80", "235")
    assert show(1e300) == "1e+300"  # no 300-digit numbers in a message


def test_rejects_condition_number_with_reason():
    strict = kin.KinematicLimits(max_condition=1.5)
    report = kin.check_points(GEOM, strict, [0.0, -0.1], [0.2, 0.12])
    assert report.ok.tolist() == [True, False]
    assert report.reasons[1] == f"Jacobian condition {report.diagnostics['condition'][1]:.3g} > 1.5"
    t1, t2 = kin.ik(GEOM, -0.1, 0.12)
    cond = np.linalg.cond(kin.jacobian(GEOM, t1, t2, -0.1, 0.12))
    assert report.diagnostics["condition"][1] == pytest.approx(cond, rel=1e-12)
    assert report.reasons[1] == "Jacobian condition 1.54 > 1.5"


def test_rejects_elbow_angle_with_reason():
    # near full stretch of arm 2 (1): the elbow at D (B) opens beyond 165 deg
    report = kin.check_points(GEOM, LIMITS, [-0.02, 0.02, -0.05], [0.31, 0.31, 0.30])
    assert report.ok.tolist() == [False, False, True]
    assert report.reasons[0].startswith("elbow angle at D 166.1 deg outside [15, 165] deg")
    assert report.reasons[1].startswith("elbow angle at B 166.1 deg outside [15, 165] deg")
    assert ";" not in report.reasons[0]


def test_require_reachable_raises_for_first_bad_point():
    x = np.array([0.0, 0.01, 0.2, 0.0])
    y = np.array([0.2, 0.2, 0.1, 0.4])
    with pytest.raises(kin.UnreachableError) as info:
        kin.require_reachable(GEOM, LIMITS, x, y)
    assert info.value.index == 2
    assert info.value.reason.startswith("motor 1 angle")
    assert "(200.000, 100.000) mm" in str(info.value)
    assert isinstance(info.value, ValueError)
    t1, t2 = kin.require_reachable(GEOM, LIMITS, x[:2], y[:2])
    np.testing.assert_array_equal(t1, kin.ik(GEOM, x[:2], y[:2])[0])
    assert t2.shape == (2,)


# FiveBarKinematics: the firmware's kinematics object ------------------------------------

KIN = kin.FiveBarKinematics(GEOM, LIMITS, "+-")


@pytest.mark.parametrize(
    "theta1, theta2, phi1, phi2",
    [  # scene.five_bar_forward(SceneConfig(), theta1, theta2) when this method was written
        (3.4033920413889427, -0.2617993877991494, -2.8109069303869374, 2.8109069303869374),
        (2.0, 1.0, -1.034338396667195, 1.1001743575806642),
        (2.6179938779914944, 0.5235987755982988, -1.9254358950316757, 1.9254358950316761),
        (1.9198621771937625, -0.5235987755982988, -1.8104598062679091, 2.3273008656294945),
        (3.6651914291880923, 1.3962634015954636, -2.2236494718946593, 1.644384277558536),
        (math.radians(200.0), math.radians(-20.0), -2.8705502843325768, 2.8705502843325763),
        (math.radians(120.0), math.radians(60.0), -1.1059630134670417, 1.1059630134670426),
        (math.radians(150.0), math.radians(-30.0), -2.3908924514470415, 2.694716095204438),
        (math.pi / 2, math.pi / 2, -0.2526802551420788, 0.2526802551420788),
    ],
)
def test_passive_angles_match_the_scene_values(theta1, theta2, phi1, phi2):
    assert KIN.passive_angles(theta1, theta2) == pytest.approx((phi1, phi2), abs=1e-12)


def test_passive_angles_close_the_chain_vectorised_and_refuse_an_open_one():
    small = kin.FiveBarKinematics(kin.FiveBarGeometry(0.04, 0.1, 0.18))
    assert small.passive_angles(2.2, 0.8) == pytest.approx(
        (-1.2913393613934394, 1.3455715703266804), abs=1e-12
    )
    theta1 = np.radians([200.0, 120.0, 150.0])
    theta2 = np.radians([-20.0, 60.0, -30.0])
    phi1, phi2 = KIN.passive_angles(theta1, theta2)
    assert phi1.shape == (3,)
    b, d = kin.elbow_points(GEOM, theta1, theta2)
    l2 = GEOM.l2_m
    c1 = b + l2 * np.stack([np.cos(theta1 + phi1), np.sin(theta1 + phi1)], axis=-1)
    c2 = d + l2 * np.stack([np.cos(theta2 + phi2), np.sin(theta2 + phi2)], axis=-1)
    np.testing.assert_allclose(c1, c2, atol=1e-12)
    np.testing.assert_allclose(c1, np.stack(KIN.planar_point(theta1, theta2), axis=-1), atol=1e-12)
    short = kin.FiveBarKinematics(kin.FiveBarGeometry(l2_m=0.1))
    with pytest.raises(ValueError, match=r"cannot close at theta=\(3.14159\d*, 0.0\)"):
        short.passive_angles([math.pi / 2, math.pi], [math.pi / 2, 0.0])


@pytest.mark.parametrize("mode", kin.MODES)
def test_point_is_the_assembly_the_mode_maps_back(mode):
    k = kin.FiveBarKinematics(GEOM, LIMITS, mode)
    x, y = workspace_points(400, seed=5)
    t1, t2 = k.planar_joints(x, y)
    ok = np.isfinite(t1) & np.isfinite(t2)
    assert ok.sum() > 300
    px, py = k.planar_point(t1[ok], t2[ok])
    np.testing.assert_allclose(px, x[ok], atol=1e-9)
    np.testing.assert_allclose(py, y[ok], atol=1e-9)
    # '-+' (elbows in) lands in the 'down' assembly: plain fk('up') would be wrong there
    x0, y0 = kin.fk(GEOM, t1[ok], t2[ok], "up")
    if mode == "-+":
        assert np.max(np.hypot(x0 - x[ok], y0 - y[ok])) > 0.01
    # scalars in, numpy scalars out
    assert np.ndim(k.planar_point(float(t1[0]), float(t2[0]))[0]) == 0


def test_point_of_steps_and_steps_of_point_invert_each_other():
    from transplanter.machine.steppers import default_drives

    drives = default_drives()
    xyz = np.array([[0.0, 0.2, 0.05], [-0.06, 0.17, 0.12], [0.08, 0.23, 0.03]])
    assert KIN.drives == drives
    steps = KIN.steps_of_point(xyz)
    assert steps.dtype == np.int64 and steps.shape == (3, 3)
    # 9600 microsteps per arm revolution, 400 per mm of Z
    assert steps[0].tolist() == [
        int(round(a * 9600 / (2 * math.pi))) for a in KIN.planar_joints(0.0, 0.2)
    ] + [20000]
    back = KIN.point_of_steps(steps)
    assert back.shape == (3, 3)
    np.testing.assert_allclose(back, xyz, atol=1e-4)  # a microstep moves C by < 0.1 mm
    np.testing.assert_array_equal(KIN.point_of_steps(steps[1]), back[1])
    with pytest.raises(ValueError, match="finite"):
        KIN.steps_of_point([0.0, 0.5, 0.05])  # out of reach: no steps


def test_homed_position_comes_from_the_kinematics_object():
    from transplanter.machine.sgf import SGFConfig

    config = SGFConfig()
    assert config.homed_steps.tolist() == [5237, -437, 63600]
    x, y, z = config.kinematics.point_of_steps(config.homed_steps)
    assert (round(x * 1e3, 3), round(y * 1e3, 3), round(z * 1e3, 3)) == (0.0, 78.988, 159.0)


def test_check_and_require_use_the_limits_and_mode():
    x = np.array([0.0, 0.0, 0.3])
    y = np.array([0.2, 0.01, 0.2])
    xyz = np.column_stack([x, y, np.full(3, 0.05)])
    report = KIN.check(xyz)
    expected = kin.check_points(GEOM, LIMITS, x, y, "+-")
    assert report.ok.tolist() == expected.ok.tolist() == [True, False, False]
    assert report.reasons == expected.reasons
    assert report.reasons[2].startswith("outside workspace: |C-O1|=")
    joints = KIN.require(xyz[:1])
    assert joints.shape == (1, 3)
    assert (joints[0, 0], joints[0, 1]) == pytest.approx(KIN.planar_joints(0.0, 0.2))
    assert joints[0, 2] == 0.05
    with pytest.raises(kin.UnreachableError) as info:
        KIN.require(xyz)
    assert info.value.index == 1


def test_kinematics_object_validates():
    with pytest.raises(ValueError, match="mode"):
        kin.FiveBarKinematics(GEOM, LIMITS, "+")
    with pytest.raises(ValueError, match="geometry"):
        kin.FiveBarKinematics((0.05, 0.12, 0.2))
    assert kin.FiveBarKinematics().assemblies == ("up", "down")
    assert kin.FiveBarKinematics(mode="-+").assemblies == ("down", "up")
