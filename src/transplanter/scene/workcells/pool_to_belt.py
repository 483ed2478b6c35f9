"""The pool_to_belt workcell of the serial arm (seed 004, Dewi et al. 2020): harvested tomatoes
queued in a sloping lane (the paper's "target pool") roll one after another to a pick station
in front of the arm, where an HC-SR04 (the paper's sensor 1) sees whether one is there; the
arm places each on a belt conveyor at its side, which carries it away
(models/workcells/pool_to_belt/, docs/serial_arm.md "The pool_to_belt workcell").

Frames (world z up, the arm's base axis at the world origin):

- the lane frame L (body ``pool``): its origin on the V-trough's bottom line, in the plane of
  the stop's face; x_L runs up the lane (world +x tilted up by the slope), z_L is normal to
  the lane. The trough's two faces rise sideways at ``trough_angle`` so a tomato rests on the
  centre line; the stop is a low box below x_L = 0, the tomatoes lean on its top edge.
- the belt frame B (body ``belt_frame``): its origin the place spot on the belt's top face,
  x_B the way the belt runs (tangential at the place spot, away from the pool), z up. The belt
  is a plate with two side walls on the slide joint ``belt`` (qpos = travel along x_B),
  driven by the actuator ``belt`` (ctrl 0 stopped, 1 running at ``belt_speed_m_s``).

`apply` writes every number of the layout from a `PoolToBeltConfig` into the spec (the XML
holds the defaults' values), `populate` adds the tomatoes (``tomato00``, ...), free bodies
queued in the lane behind the station.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import mujoco
import numpy as np

from transplanter.scene.config import BIT_GRIPPER, BIT_POT, BIT_WORLD

__all__ = [
    "BELT_ON",
    "JUDGE",
    "MODEL",
    "PoolToBeltConfig",
    "Tomato",
    "apply",
    "as_pool_config",
    "belt_travel_m",
    "draw_tomatoes",
    "home_joints",
    "leaf_proxies",
    "on_belt",
    "place_xyz",
    "pool_config",
    "populate",
    "start_belt",
    "station_distances",
    "station_xyz",
    "tomato_name",
]

MODEL = "pool_to_belt"
"""The workcell's folder: models/workcells/pool_to_belt/pool_to_belt.xml."""
JUDGE = "transplanter.twin.serial_arm:PoolToBeltJudge"
"""The judge of the pick-and-place job ("module:Class")."""

BELT_ON = 1.0
"""The belt actuator's ctrl while the belt runs (0: stopped; the speed is in the model)."""

# Constants of the build (not scenario keys: they shape the parts, not the job).
TROUGH_THICKNESS_M = 0.003
STOP_THICKNESS_M = 0.006
STOP_HALF_WIDTH_M = 0.010  # the stop is a tab on the lane's centre line, between the fingers
LANE_END_MARGIN_M = 0.030  # lane length beyond the queue of count largest tomatoes
SIDE_WALL_HEIGHT_M = 0.030  # above the trough's rim, along the queue (not at the station)
SIDE_WALL_CLEARANCE_M = 0.012  # side walls start this far beyond the largest lead tomato
QUEUE_GAP_M = 0.001  # between queued tomatoes as built (they close up as they settle)
BELT_THICKNESS_M = 0.004
BELT_MARGIN_M = 0.100  # belt plate beyond the place spot, downstream and upstream at the end
BELT_SIDEWALL_THICKNESS_M = 0.003
BELT_PLATE_MASS_KG = 0.3
BELT_KV_N_S_M = 50.0  # the belt drive's velocity gain (a geared DC motor, stiff): estimate
BELT_FORCE_LIMIT_N = 20.0
BELT_BED_LENGTH_M = 0.30  # the static frame drawn under the belt around the place spot
TORSIONAL_FRICTION = 0.005
SENSOR_HALF_SIZE_M = (0.022, 0.008, 0.010)  # HC-SR04 board, 45 x 20 mm (+ transducers)
TOMATO_SOLIMP = (0.9, 0.95, 0.001, 0.5, 2.0)


@dataclass(frozen=True)
class PoolToBeltConfig:
    """Every number of the layout and of the tomatoes' draws, SI. The fields are the
    `[pool_to_belt]` keys (the file writes them in mm, deg, g, ms, mm/s); marks: **paper**,
    **estimate** (docs/serial_arm.md)."""

    count: int = 6
    """Tomatoes queued in the pool (estimate: the paper picks them one by one)."""
    diameter_min_m: float = 0.050
    diameter_max_m: float = 0.070
    """Tomato diameters, drawn uniformly (estimate: round table tomatoes)."""
    mass_min_kg: float = 0.070
    mass_max_kg: float = 0.150
    """Masses: density x volume, clipped to this range (estimate)."""
    density_kg_m3: float = 1000.0
    """Tomato density (estimate: tomatoes barely float, 0.95-1.02 g/cm^3)."""
    friction_low: float = 0.4
    friction_high: float = 0.8
    """Sliding friction of the skin against the gripper's pads, drawn uniformly (estimate:
    a waxy skin on rubber)."""
    contact_timeconst_s: float = 0.008
    """Contact time constant of a tomato (solref, damping ratio 1): a soft fruit (estimate)."""
    rolling_resistance_m: float = 0.001
    """Rolling friction (MuJoCo's, a length) of the lane's and the belt's faces against a
    tomato: a soft fruit flattens where it rests (estimate, ~0.03 of the radius)."""
    station_x_m: float = 0.115
    station_y_m: float = 0.0
    """World point under which a tomato of the middle diameter rests at the pick station (in
    front of the arm, 115 mm from its base axis: estimate in the comfortable reach)."""
    lane_floor_z_m: float = 0.020
    """Height of the trough's bottom line at the stop above the floor."""
    lane_slope_rad: float = math.radians(5.0)
    """The lane's slope down to the stop (estimate: a few degrees, above the rolling
    resistance's rolling_resistance / radius)."""
    trough_angle_rad: float = math.radians(12.0)
    """Each trough face's rise sideways: centres the tomatoes on the lane's line."""
    lane_half_width_m: float = 0.040
    """Half width of the trough (its rim sideways from the centre line)."""
    stop_height_m: float = 0.030
    """The stop's top edge above the trough's bottom line. The stop is a tab 20 mm wide on
    the lane's centre line, so the fingers, closing from the sides, pass beside it; it
    reaches about the tomatoes' centre height, since a queue pushing a lead tomato against a
    low edge rolls it over the edge (its spin climbs it)."""
    sensor_offset_m: float = 0.055
    """Sensor 1's face sideways from the station's centre line (on the belt's side, looking
    across the station away from the belt)."""
    place_angle_rad: float = math.radians(90.0)
    """The base angle theta1 of the place spot (the paper's frame: positive to the right,
    world -y)."""
    place_radius_m: float = 0.115
    """The place spot's distance from the base axis."""
    belt_top_z_m: float = 0.025
    """The belt's top face above the floor."""
    belt_width_m: float = 0.080
    """Between the belt's side walls."""
    belt_sidewall_height_m: float = 0.020
    """The belt's side walls (a sidewall belt: they run with it) above its top face."""
    belt_speed_m_s: float = 0.025
    """The belt's speed (estimate: a small hobby conveyor)."""
    cycle_s: float = 12.0
    """Time per pick-and-place the belt is sized for: its plate carries count x cycle_s x
    belt_speed of travel before it reaches its end stop."""
    release_gap_m: float = 0.010
    """Gap between a tomato's bottom and the belt where place_xyz releases it."""

    def __post_init__(self) -> None:
        checks = (
            (self.count >= 0, "count must be 0 (an empty pool: a bench) or more"),
            (0 < self.diameter_min_m <= self.diameter_max_m, "0 < diameter_min <= diameter_max"),
            (0 < self.mass_min_kg <= self.mass_max_kg, "0 < mass_min <= mass_max"),
            (0 <= self.friction_low <= self.friction_high, "0 <= friction_low <= friction_high"),
            (
                self.lane_half_width_m
                > 0.5 * self.diameter_max_m * math.sin(self.trough_angle_rad),
                "the trough's faces must reach the largest tomato's contacts",
            ),
            (
                self.diameter_max_m / 2 < self.sensor_offset_m,
                "sensor_offset must exceed the largest tomato's radius",
            ),
            (self.belt_width_m > self.diameter_max_m, "belt_width must exceed diameter_max"),
            (self.belt_speed_m_s > 0 and self.cycle_s > 0, "belt_speed and cycle > 0"),
        )
        for ok, why in checks:
            if not ok:
                raise ValueError(f"PoolToBeltConfig: {why}")

    # --- derived numbers -------------------------------------------------------------------

    @property
    def nominal_diameter_m(self) -> float:
        """The middle of the diameter range: its tomato rests at (station_x, station_y)."""
        return 0.5 * (self.diameter_min_m + self.diameter_max_m)

    @property
    def lane_length_m(self) -> float:
        """The lane from the stop to its upper end: count of the largest tomatoes + margin
        (an empty pool's lane holds one)."""
        return max(self.count, 1) * (self.diameter_max_m + QUEUE_GAP_M) + LANE_END_MARGIN_M

    @property
    def belt_travel_max_m(self) -> float:
        """The belt's travel until its end stop: count x cycle_s x belt_speed (an empty
        pool's belt: one cycle's)."""
        return max(self.count, 1) * self.cycle_s * self.belt_speed_m_s

    @property
    def belt_length_m(self) -> float:
        return self.belt_travel_max_m + 2 * BELT_MARGIN_M


def as_pool_config(cfg) -> PoolToBeltConfig:
    """The workcell's config from what a caller holds: a PoolToBeltConfig, or a config with a
    `pool_to_belt` attribute (a scene's config); else the defaults."""
    if isinstance(cfg, PoolToBeltConfig):
        return cfg
    return getattr(cfg, "pool_to_belt", None) or PoolToBeltConfig()


def pool_config(sc) -> PoolToBeltConfig:
    """The scenario's `[pool_to_belt]` as a PoolToBeltConfig (the section's fields are the
    config's, SI); a value the config refuses is a ScenarioError."""
    from transplanter.scenario.schema import ScenarioError

    section = sc.pool_to_belt
    try:
        return PoolToBeltConfig(**{f.name: getattr(section, f.name) for f in fields(section)})
    except ValueError as exc:
        raise ScenarioError(f"the scenario's [pool_to_belt]: {exc}") from None


# --- geometry -------------------------------------------------------------------------------


def _lane_rotation(cfg: PoolToBeltConfig) -> np.ndarray:
    """World axes of the lane frame (columns): x_L up the lane, z_L normal to it."""
    b = cfg.lane_slope_rad
    return np.array(
        [[math.cos(b), 0.0, -math.sin(b)], [0.0, 1.0, 0.0], [math.sin(b), 0.0, math.cos(b)]]
    )


def _lane_quat(cfg: PoolToBeltConfig) -> list[float]:
    half = -0.5 * cfg.lane_slope_rad  # about world y by -slope: x_L rises
    return [math.cos(half), 0.0, math.sin(half), 0.0]


def _rest_in_lane(cfg: PoolToBeltConfig, diameter_m: float) -> tuple[float, float]:
    """(x_L, z_L) of a lead tomato's centre resting on the trough against the stop's edge."""
    r = 0.5 * diameter_m
    zc = r / math.cos(cfg.trough_angle_rad)
    rise = zc - cfg.stop_height_m
    s = math.sqrt(r * r - rise * rise) if rise > 0 else r
    return s, zc


def _lane_origin(cfg: PoolToBeltConfig) -> np.ndarray:
    """World position of the lane frame's origin (chosen so the middle tomato rests under
    (station_x, station_y))."""
    s, zc = _rest_in_lane(cfg, cfg.nominal_diameter_m)
    offset = _lane_rotation(cfg) @ np.array([s, 0.0, zc])
    return np.array([cfg.station_x_m - offset[0], cfg.station_y_m, cfg.lane_floor_z_m])


def _lane_to_world(cfg: PoolToBeltConfig, p_lane) -> np.ndarray:
    return _lane_origin(cfg) + _lane_rotation(cfg) @ np.asarray(p_lane, dtype=float)


def station_xyz(cfg: PoolToBeltConfig, diameter_m: float | None = None) -> np.ndarray:
    """World point (m) of the centre of a lead tomato of that diameter (default the middle
    one) resting at the pick station."""
    d = cfg.nominal_diameter_m if diameter_m is None else diameter_m
    s, zc = _rest_in_lane(cfg, d)
    return _lane_to_world(cfg, [s, 0.0, zc])


def _belt_axis(cfg: PoolToBeltConfig) -> np.ndarray:
    """World unit vector the belt runs along: tangential at the place spot, away from the
    pool (theta1 = 90 deg: world -x)."""
    t = cfg.place_angle_rad
    return np.array([-math.sin(t), -math.cos(t), 0.0])


def _place_spot(cfg: PoolToBeltConfig) -> np.ndarray:
    """The place spot on the belt's top face (world): theta1 = place_angle, paper frame z to
    the right (world -y)."""
    t, r = cfg.place_angle_rad, cfg.place_radius_m
    return np.array([r * math.cos(t), -r * math.sin(t), cfg.belt_top_z_m])


def place_xyz(cfg: PoolToBeltConfig, diameter_m: float | None = None) -> np.ndarray:
    """World point (m) where the arm releases a tomato of that diameter's centre over the
    place spot: release_gap above the belt (belt at rest position)."""
    d = cfg.nominal_diameter_m if diameter_m is None else diameter_m
    return _place_spot(cfg) + np.array([0.0, 0.0, 0.5 * d + cfg.release_gap_m])


def belt_travel_m(data: mujoco.MjData) -> float:
    """How far the belt has moved (m) since it was built (its slide's position)."""
    return float(data.joint("belt").qpos[0])


def start_belt(data: mujoco.MjData, on: bool = True) -> None:
    """Run (or stop) the belt: its actuator's ctrl BELT_ON (or 0)."""
    data.actuator("belt").ctrl[0] = BELT_ON if on else 0.0


def on_belt(
    model: mujoco.MjModel, data: mujoco.MjData, cfg: PoolToBeltConfig, body_name: str
) -> bool:
    """True if the body's centre lies over the belt plate as it is now (between its side
    walls, within its length) and no higher above the belt's top face than the largest
    tomato's radius + 5 mm: it rests (or rolls) on the belt."""
    frame = data.body("belt_frame")
    rot = frame.xmat.reshape(3, 3)
    local = rot.T @ (data.body(body_name).xpos - frame.xpos)
    travel = belt_travel_m(data)
    lo = travel - cfg.belt_travel_max_m - BELT_MARGIN_M
    hi = travel + BELT_MARGIN_M
    return bool(
        lo <= local[0] <= hi
        and abs(local[1]) <= 0.5 * cfg.belt_width_m
        and 0.0 < local[2] <= 0.5 * cfg.diameter_max_m + 0.005
    )


def station_distances(
    model: mujoco.MjModel, data: mujoco.MjData, directions: np.ndarray | None = None
) -> np.ndarray:
    """True distances (m; -1 where nothing is hit) along rays from the site `station_sensor`,
    one per direction in the site's frame (default its axis; an HC-SR04's cone:
    UltrasonicSensor.beam_directions()), the sensor's own body excluded. Feed them to
    UltrasonicSensor.reading."""
    site = data.site("station_sensor")
    dirs = np.array([[0.0, 0.0, 1.0]]) if directions is None else np.asarray(directions, float)
    rot = site.xmat.reshape(3, 3)
    exclude = int(model.site("station_sensor").bodyid[0])
    geomid = np.zeros(1, dtype=np.int32)
    out = np.empty(len(dirs))
    for k, d in enumerate(dirs):
        vec = rot @ d
        out[k] = mujoco.mj_ray(model, data, site.xpos, vec, None, 1, exclude, geomid)
    return out


# --- the tomatoes -----------------------------------------------------------------------------


@dataclass(frozen=True)
class Tomato:
    """One drawn tomato: its size, mass, skin friction, colour and start pose (world)."""

    index: int
    diameter_m: float
    mass_kg: float
    friction: float
    ripeness: float
    """0 green .. 1 red (its colour only)."""
    pos: tuple[float, float, float]

    @property
    def name(self) -> str:
        return tomato_name(self.index)

    @property
    def radius_m(self) -> float:
        return 0.5 * self.diameter_m


def tomato_name(index: int) -> str:
    """The body (and collision geom) name of tomato `index`: tomato00, tomato01, ..."""
    return f"tomato{index:02d}"


def _queue_positions(cfg: PoolToBeltConfig, diameters: np.ndarray) -> list[np.ndarray]:
    """World centres of the tomatoes queued in the lane, the first against the stop, each
    next one QUEUE_GAP behind the one before along the lane's centre line."""
    if len(diameters) == 0:  # an empty pool (a bench)
        return []
    cos_a = math.cos(cfg.trough_angle_rad)
    s, zc = _rest_in_lane(cfg, float(diameters[0]))
    out = [_lane_to_world(cfg, [s, 0.0, zc])]
    for prev, d in zip(diameters[:-1], diameters[1:], strict=True):
        r0, r1 = 0.5 * prev, 0.5 * d
        dz = (r1 - r0) / cos_a
        dx = math.sqrt((r0 + r1 + QUEUE_GAP_M) ** 2 - dz * dz)
        s, zc = s + dx, r1 / cos_a
        out.append(_lane_to_world(cfg, [s, 0.0, zc]))
    return out


def draw_tomatoes(cfg: PoolToBeltConfig, seed: int) -> tuple[Tomato, ...]:
    """cfg.count tomatoes drawn from numpy's default_rng(seed) (deterministic): diameter and
    friction uniform in their ranges, mass density x volume clipped to the mass range,
    queued in the lane (tomato 0 at the station)."""
    rng = np.random.default_rng(seed)
    n = cfg.count
    diameter = rng.uniform(cfg.diameter_min_m, cfg.diameter_max_m, n)
    friction = rng.uniform(cfg.friction_low, cfg.friction_high, n)
    ripeness = rng.uniform(0.0, 1.0, n)
    mass = np.clip(cfg.density_kg_m3 * math.pi / 6 * diameter**3, cfg.mass_min_kg, cfg.mass_max_kg)
    pos = _queue_positions(cfg, diameter)
    return tuple(
        Tomato(
            i,
            float(diameter[i]),
            float(mass[i]),
            float(friction[i]),
            float(ripeness[i]),
            tuple(float(v) for v in pos[i]),
        )  # fmt: skip
        for i in range(n)
    )


def populate(
    spec: mujoco.MjSpec, cfg: PoolToBeltConfig, seed: int, decor: bool = True
) -> tuple[Tomato, ...]:
    """A free body per drawn tomato (``tomato00``, ...) queued in the lane: a sphere of its
    diameter, mass and solid-sphere inertia, its friction (priority 1: it decides against
    the pads; the lane's and belt's faces have priority 2), a soft contact; with `decor` a
    calyx drawn on top. Returns the draws."""
    cfg = as_pool_config(cfg)
    tomatoes = draw_tomatoes(cfg, seed)
    for t in tomatoes:
        body = spec.worldbody.add_body()
        body.name = t.name
        body.pos = list(t.pos)
        body.add_freejoint()
        body.mass = t.mass_kg
        body.ipos = [0.0, 0.0, 0.0]
        body.iquat = [1.0, 0.0, 0.0, 0.0]
        body.inertia = [0.4 * t.mass_kg * t.radius_m**2] * 3
        body.explicitinertial = True
        g = body.add_geom()
        g.name = t.name
        g.type = mujoco.mjtGeom.mjGEOM_SPHERE
        g.size = [t.radius_m, 0, 0]
        g.contype = BIT_POT
        g.conaffinity = BIT_WORLD | BIT_POT | BIT_GRIPPER
        g.condim = 6
        g.priority = 1
        g.friction = [t.friction, TORSIONAL_FRICTION, cfg.rolling_resistance_m]
        g.solref = [cfg.contact_timeconst_s, 1.0]
        g.solimp = list(TOMATO_SOLIMP)
        green, red = np.array([0.30, 0.55, 0.15]), np.array([0.80, 0.10, 0.05])
        g.rgba = [*(green + t.ripeness * (red - green)), 1.0]
        g.mass = 0
        if decor:
            calyx = body.add_geom()
            calyx.type = mujoco.mjtGeom.mjGEOM_CYLINDER
            calyx.size = [0.25 * t.radius_m, 0.002, 0]
            calyx.pos = [0, 0, t.radius_m - 0.001]
            calyx.contype = calyx.conaffinity = 0
            calyx.group = 2
            calyx.mass = 0
            calyx.rgba = [0.2, 0.45, 0.1, 1.0]
    return tomatoes


def leaf_proxies(cfg: PoolToBeltConfig, pots) -> tuple:
    """Tomatoes have no leaves the scene tests for contact."""
    return ()


def home_joints(cfg: PoolToBeltConfig) -> dict[str, float]:
    """The belt at 0 (the tomatoes' free joints start where they are built)."""
    return {"belt": 0.0}


# --- the layout into the spec ----------------------------------------------------------------


def _set_box(geom, half, pos, quat=(1.0, 0.0, 0.0, 0.0)) -> None:
    geom.size = [float(v) for v in half]
    geom.pos = [float(v) for v in pos]
    geom.quat = [float(v) for v in quat]


def _rot_x(angle: float) -> list[float]:
    return [math.cos(angle / 2), math.sin(angle / 2), 0.0, 0.0]


def apply(spec: mujoco.MjSpec, cfg: PoolToBeltConfig) -> None:
    """Write the layout of `cfg` into the spec: the lane (trough faces, stop, side walls, end
    wall), sensor 1, the belt (frame, plate, side walls, travel, drive speed), the contact
    parameters of the faces. The XML holds the values of PoolToBeltConfig()."""
    cfg = as_pool_config(cfg)
    _apply_pool(spec, cfg)
    _apply_sensor(spec, cfg)
    _apply_belt(spec, cfg)


def _apply_pool(spec: mujoco.MjSpec, cfg: PoolToBeltConfig) -> None:
    pool = spec.body("pool")
    pool.pos = [float(v) for v in _lane_origin(cfg)]
    pool.quat = _lane_quat(cfg)
    a, t, length = cfg.trough_angle_rad, TROUGH_THICKNESS_M, cfg.lane_length_m
    x0 = -STOP_THICKNESS_M
    x_mid, x_half = 0.5 * (x0 + length), 0.5 * (length - x0)
    width = cfg.lane_half_width_m / math.cos(a) + t  # along the face, past the bottom line
    for side, name in ((1.0, "trough_left"), (-1.0, "trough_right")):
        u = np.array([0.0, side * math.cos(a), math.sin(a)])  # up the face, away from the line
        n = np.array([0.0, -side * math.sin(a), math.cos(a)])  # the face's normal
        centre = np.array([x_mid, 0.0, 0.0]) + (0.5 * width - t) * u - 0.5 * t * n
        _set_box(spec.geom(name), [x_half, 0.5 * width, 0.5 * t], centre, _rot_x(side * a))
    rim = cfg.lane_half_width_m * math.tan(a)
    depth = 0.010  # the stop and the walls reach below the faces
    _set_box(
        spec.geom("stop"),
        [0.5 * STOP_THICKNESS_M, STOP_HALF_WIDTH_M, 0.5 * (cfg.stop_height_m + depth)],
        [-0.5 * STOP_THICKNESS_M, 0.0, 0.5 * (cfg.stop_height_m - depth)],
    )
    top = rim + SIDE_WALL_HEIGHT_M
    _set_box(
        spec.geom("lane_end"),
        [0.5 * STOP_THICKNESS_M, cfg.lane_half_width_m, 0.5 * (top + depth)],
        [length + 0.5 * STOP_THICKNESS_M, 0.0, 0.5 * (top - depth)],
    )
    s_lead, _ = _rest_in_lane(cfg, cfg.diameter_max_m)
    start = s_lead + 0.5 * cfg.diameter_max_m + SIDE_WALL_CLEARANCE_M
    for side, name in ((1.0, "lane_wall_left"), (-1.0, "lane_wall_right")):
        _set_box(
            spec.geom(name),
            [0.5 * (length - start), 0.5 * STOP_THICKNESS_M, 0.5 * (top + depth)],
            [0.5 * (length + start), side * (cfg.lane_half_width_m + 0.5 * STOP_THICKNESS_M),
             0.5 * (top - depth)],
        )  # fmt: skip
    for geom in pool.geoms:
        if geom.contype:
            geom.friction = [geom.friction[0], TORSIONAL_FRICTION, cfg.rolling_resistance_m]


def _apply_sensor(spec: mujoco.MjSpec, cfg: PoolToBeltConfig) -> None:
    centre = station_xyz(cfg)
    face = np.array([centre[0], cfg.station_y_m - cfg.sensor_offset_m, centre[2]])
    body = spec.body("station_sensor")
    body.pos = [float(v) for v in face]
    # the board behind the face (world -y), the site on the face looking +y
    _set_box(spec.geom("station_sensor_board"), SENSOR_HALF_SIZE_M, [0, -SENSOR_HALF_SIZE_M[1], 0])
    site = spec.site("station_sensor")
    site.pos = [0.0, 0.0, 0.0]
    site.quat = _rot_x(-0.5 * math.pi)  # site +z = world +y
    post = spec.geom("station_sensor_post")
    height = centre[2] - SENSOR_HALF_SIZE_M[2]
    post.size = [0.004, 0.5 * height, 0.0]
    post.pos = [0.0, -SENSOR_HALF_SIZE_M[1], -SENSOR_HALF_SIZE_M[2] - 0.5 * height]


def _apply_belt(spec: mujoco.MjSpec, cfg: PoolToBeltConfig) -> None:
    frame = spec.body("belt_frame")
    frame.pos = [float(v) for v in _place_spot(cfg)]
    axis = _belt_axis(cfg)
    yaw = math.atan2(axis[1], axis[0])
    frame.quat = [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]
    travel, length = cfg.belt_travel_max_m, cfg.belt_length_m
    x_mid = BELT_MARGIN_M - 0.5 * length  # the plate: from -(travel + margin) to +margin
    _set_box(
        spec.geom("belt_plate"),
        [0.5 * length, 0.5 * cfg.belt_width_m + BELT_SIDEWALL_THICKNESS_M, 0.5 * BELT_THICKNESS_M],
        [x_mid, 0.0, -0.5 * BELT_THICKNESS_M],
    )
    plate = spec.geom("belt_plate")
    plate.friction = [plate.friction[0], TORSIONAL_FRICTION, cfg.rolling_resistance_m]
    for side, name in ((1.0, "belt_wall_left"), (-1.0, "belt_wall_right")):
        _set_box(
            spec.geom(name),
            [0.5 * length, 0.5 * BELT_SIDEWALL_THICKNESS_M, 0.5 * cfg.belt_sidewall_height_m],
            [x_mid, side * 0.5 * (cfg.belt_width_m + BELT_SIDEWALL_THICKNESS_M),
             0.5 * cfg.belt_sidewall_height_m],
        )  # fmt: skip
    bed_h = cfg.belt_top_z_m - BELT_THICKNESS_M
    _set_box(
        spec.geom("belt_bed"),
        [0.5 * BELT_BED_LENGTH_M, 0.5 * cfg.belt_width_m, 0.5 * bed_h],
        [0.0, 0.0, -BELT_THICKNESS_M - 0.5 * bed_h],
    )
    spec.body("belt").mass = BELT_PLATE_MASS_KG
    joint = spec.joint("belt")
    joint.range = [-0.005, travel]
    act = spec.actuator("belt")
    act.gainprm = [BELT_KV_N_S_M * cfg.belt_speed_m_s] + [0.0] * 9
    act.biasprm = [0.0, 0.0, -BELT_KV_N_S_M] + [0.0] * 7
    act.forcerange = [-BELT_FORCE_LIMIT_N, BELT_FORCE_LIMIT_N]
