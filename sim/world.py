"""The MuJoCo world of a scene, built with ``mujoco.MjSpec`` (no XML templates).

Contents: a floor plane, the room outline and interior walls as boxes, box obstacles, lights
(no shadows unless ``scene.render.shadows``), the scene's cameras, and one body per walker: a
vertical capsule of the walker's height, radius and colour on slide joints x, y, z and a hinge
about z (yaw), compensated for gravity (``gravcomp=1``) so writing its kinematics is enough.

Walker kinematics are written to ``qpos``/``qvel``/``qacc`` and ``mj_inverse``'s stages compute the
sensors (mocap bodies would read zero acceleration: FACTS.md). The body frame's origin is the
body centre; the slide joints' qpos are therefore the world position of the centre and the
hinge's qpos the yaw.

Each walker with a phone carries a site ``<name>_phone`` on its vertical axis (at pocket
height, 1.0 m above the floor when standing) with an accelerometer (specific force
R^T (a - g), m/s^2), a gyro (R^T omega, rad/s) and a magnetometer (R^T m with m =
``option.magnetic``), R the site's world rotation (the body's yaw). On the axis, the lever-arm
terms omega x (omega x r) and alpha x r vanish, so the accelerometer reads the body centre's
acceleration.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from trackroom.scenes.spec import Scene

PHONE_HEIGHT = 1.0  # m above the floor
PERSON_GROUP = 2  # geom group of people (visible by default)


@dataclass
class World:
    """A compiled scene plus the index maps the simulator and renderer need.

    person_body[i], person_geom[i]: body and geom ids of walker i (scene order).
    geom_person: geom id -> person index (-1 for anything else), for segmentation masks and rays.
    qpos_adr[i], qvel_adr[i]: first address of walker i's 4 joints (x, y, z, yaw).
    phone_sensors[i]: (accelerometer, gyro, magnetometer) sensordata addresses, or None.
    camera_ids: camera name -> MuJoCo camera id.
    """

    scene: Scene
    spec: mujoco.MjSpec
    model: mujoco.MjModel
    data: mujoco.MjData
    person_body: np.ndarray
    person_geom: np.ndarray
    geom_person: np.ndarray
    qpos_adr: np.ndarray
    qvel_adr: np.ndarray
    phone_sensors: list
    phone_site: list
    camera_ids: dict = field(default_factory=dict)

    @property
    def n_people(self) -> int:
        return len(self.person_body)

    def packed(self, traj) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """qpos, qvel, qacc of every trajectory step, (N, nq), (N, nv), (N, nv), built once per
        trajectory (a per-step write is then one array copy)."""
        cache = getattr(self, "_packed", None)
        if cache is None or cache[0] is not traj:
            m = self.model
            N = traj.n_steps
            V = np.zeros((N, m.nv))
            A = np.zeros((N, m.nv))
            for i in range(self.n_people):
                v = self.qvel_adr[i]
                V[:, v : v + 3] = traj.vel[i]
                V[:, v + 3] = traj.yaw_rate[i]
                A[:, v : v + 3] = traj.acc[i]
                A[:, v + 3] = traj.yaw_acc[i]
            self._packed = cache = (traj, self.packed_positions(traj), V, A)
        return cache[1], cache[2], cache[3]

    def packed_positions(self, traj) -> np.ndarray:
        """qpos of every trajectory step (N, nq), built once per trajectory (posing the world for
        ray casts and rendering needs no velocities)."""
        cache = getattr(self, "_packed_q", None)
        if cache is None or cache[0] is not traj:
            Q = np.tile(self.model.qpos0, (traj.n_steps, 1))
            for i in range(self.n_people):
                q = self.qpos_adr[i]
                Q[:, q : q + 3] = traj.pos[i]
                Q[:, q + 3] = traj.yaw[i]
            self._packed_q = cache = (traj, Q)
        return cache[1]

    def write_state(self, traj, k: int, with_derivatives: bool = True) -> None:
        """Write every walker's qpos (and qvel, qacc) at trajectory step k."""
        d = self.data
        if with_derivatives:
            Q, V, A = self.packed(traj)
            d.qvel[:] = V[k]
            d.qacc[:] = A[k]
        else:
            Q = self.packed_positions(traj)
        d.qpos[:] = Q[k]

    def set_step(self, traj, k: int) -> None:
        """Put the world at trajectory step k: qpos, qvel, qacc, then ``sense`` (positions,
        velocities, accelerations and sensors, keeping the written qacc)."""
        self.write_state(traj, k, True)
        self.sense()

    def sense(self) -> None:
        """Poses and sensor readings for the qpos, qvel, qacc written in ``data``: the stages of
        ``mj_inverse`` that the sensors read (kinematics, centre-of-mass positions and velocities,
        the body accelerations ``cacc`` of ``mj_rnePostConstraint``, then the sensors), not the
        inverse dynamics (forces, constraints) it also computes. The same functions give the same
        bits as ``mj_inverse`` (tests/test_imu.py) at half its cost."""
        m, d = self.model, self.data
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_comVel(m, d)
        mujoco.mj_sensorPos(m, d)
        mujoco.mj_sensorVel(m, d)
        mujoco.mj_rnePostConstraint(m, d)
        mujoco.mj_sensorAcc(m, d)

    def set_pose(self, traj, k: int) -> None:
        """Positions only (``mj_kinematics``): enough for ray casts and rendering."""
        self.write_state(traj, k, False)
        mujoco.mj_kinematics(self.model, self.data)

    def phone_reading(self, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Noise-free (accelerometer, gyro, magnetometer) of walker i's phone, phone frame."""
        a, g, m = self.phone_sensors[i]
        s = self.data.sensordata
        return s[a : a + 3].copy(), s[g : g + 3].copy(), s[m : m + 3].copy()

    def to_xml(self) -> str:
        return self.spec.to_xml()


def _box(parent, name, pos, size, yaw=0.0, rgba=(0.8, 0.8, 0.8, 1.0)):
    g = parent.add_geom()
    g.name = name
    g.type = mujoco.mjtGeom.mjGEOM_BOX
    g.pos = list(map(float, pos))
    g.size = list(map(float, size))
    g.quat = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
    g.rgba = list(rgba)
    return g


def new_spec(scene: Scene) -> mujoco.MjSpec:
    """An empty ``MjSpec`` with the scene's options (name, magnetic field, time step; default gravity)."""
    spec = mujoco.MjSpec()
    spec.modelname = scene.name
    spec.option.magnetic = list(map(float, scene.sensors.magnetic_field))
    spec.option.timestep = 1.0 / scene.sensors.sim_rate
    return spec


def add_walker(spec: mujoco.MjSpec, w, name: str):
    """Walker ``w``'s body ``name`` in ``spec``'s world: a capsule on slide joints x, y, z and a yaw
    hinge (``name``_x, _y, _z, _yaw; geom ``name``_body), and with a phone a site ``name``_phone
    carrying the accelerometer, gyro and magnetometer ``name``_acc, _gyro, _mag (module docstring).
    One definition for the scene's world and the phone-only batch world of ``sim.imu``, so the two
    compute the same sensor readings."""
    body = spec.worldbody.add_body()
    body.name = name
    body.gravcomp = 1.0
    for axis, jname in (((1, 0, 0), "x"), ((0, 1, 0), "y"), ((0, 0, 1), "z")):
        jt = body.add_joint()
        jt.name = f"{name}_{jname}"
        jt.type = mujoco.mjtJoint.mjJNT_SLIDE
        jt.axis = list(axis)
    jt = body.add_joint()
    jt.name = f"{name}_yaw"
    jt.type = mujoco.mjtJoint.mjJNT_HINGE
    jt.axis = [0, 0, 1]
    g = body.add_geom()
    g.name = f"{name}_body"
    g.type = mujoco.mjtGeom.mjGEOM_CAPSULE
    g.size = [w.radius, max(0.5 * w.height - w.radius, 1e-3), 0.0]
    g.rgba = [*w.color, 1.0]
    g.group = PERSON_GROUP
    g.mass = 70.0
    g.contype = 0  # people are kinematic: no contacts
    g.conaffinity = 0
    if w.phone:
        site = body.add_site()
        site.name = f"{name}_phone"
        site.pos = [0.0, 0.0, PHONE_HEIGHT - 0.5 * w.height]
        site.size = [0.02, 0.02, 0.02]
        for stype, suffix in ((mujoco.mjtSensor.mjSENS_ACCELEROMETER, "acc"), (mujoco.mjtSensor.mjSENS_GYRO, "gyro"), (mujoco.mjtSensor.mjSENS_MAGNETOMETER, "mag")):
            s = spec.add_sensor()
            s.name = f"{name}_{suffix}"
            s.type = stype
            s.objtype = mujoco.mjtObj.mjOBJ_SITE
            s.objname = site.name
    return body


def build_world(scene: Scene) -> World:
    """Compile ``scene`` into a MuJoCo model (see the module docstring for what it holds)."""
    spec = new_spec(scene)
    fp = scene.floorplan
    x0, y0, x1, y1 = fp.bounds()
    world = spec.worldbody

    floor = world.add_geom()
    floor.name = "floor"
    floor.type = mujoco.mjtGeom.mjGEOM_PLANE
    floor.pos = [(x0 + x1) / 2, (y0 + y1) / 2, 0.0]
    floor.size = [(x1 - x0) / 2 + 1.0, (y1 - y0) / 2 + 1.0, 0.1]
    floor.rgba = [0.55, 0.55, 0.5, 1.0]

    for kind, walls in (("outline", fp.outline_walls()), ("wall", fp.walls)):
        for j, w in enumerate(walls):
            a, b = np.asarray(w.start, float), np.asarray(w.end, float)
            length = float(np.linalg.norm(b - a))
            yaw = float(np.arctan2(b[1] - a[1], b[0] - a[0]))
            # half-length extended by half the thickness so corners close
            _box(world, f"{kind}{j}", [*(0.5 * (a + b)), 0.5 * w.height], [0.5 * length + 0.5 * w.thickness, 0.5 * w.thickness, 0.5 * w.height], yaw, (0.85, 0.83, 0.78, 1.0))
    for j, o in enumerate(fp.obstacles):
        # prefixed: an obstacle named "floor" or "wall0" must not collide with the geoms above
        _box(world, f"obstacle/{o.name or j}", [*o.center, 0.5 * o.size[2]], [0.5 * s for s in o.size], o.yaw, (0.45, 0.35, 0.25, 1.0))

    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    for j, pos in enumerate(([cx, cy, fp.wall_height + 2.0], [x0 + 1, y0 + 1, fp.wall_height + 1.0])):
        light = world.add_light()
        light.name = f"light{j}"
        light.pos = pos
        light.dir = [0.0, 0.0, -1.0]
        light.castshadow = bool(scene.render.shadows)
        light.diffuse = [0.6, 0.6, 0.6] if j == 0 else [0.3, 0.3, 0.3]

    for cam in scene.cameras:
        c = world.add_camera()
        c.name = cam.name
        c.pos = list(map(float, cam.position))
        c.alt.type = mujoco.mjtOrientation.mjORIENTATION_XYAXES
        c.alt.xyaxes = list(map(float, cam.mujoco_xyaxes()))
        c.fovy = float(np.degrees(cam.fovy))
        c.resolution = [cam.width, cam.height]  # used by the camprojection sensor
    if scene.cameras:
        spec.visual.global_.offwidth = max(640, max(c.width for c in scene.cameras))
        spec.visual.global_.offheight = max(480, max(c.height for c in scene.cameras))

    for w in scene.walkers:
        add_walker(spec, w, w.name)

    model = spec.compile()
    data = mujoco.MjData(model)
    P = len(scene.walkers)
    body_ids = np.array([model.body(w.name).id for w in scene.walkers], int)
    geom_ids = np.array([model.geom(f"{w.name}_body").id for w in scene.walkers], int)
    geom_person = np.full(model.ngeom, -1, int)
    geom_person[geom_ids] = np.arange(P)
    qpos_adr = np.array([model.jnt_qposadr[model.joint(f"{w.name}_x").id] for w in scene.walkers], int)
    qvel_adr = np.array([model.jnt_dofadr[model.joint(f"{w.name}_x").id] for w in scene.walkers], int)
    sensors, sites = [], []
    for w in scene.walkers:
        if w.phone:
            sensors.append(tuple(int(model.sensor_adr[model.sensor(f"{w.name}_{s}").id]) for s in ("acc", "gyro", "mag")))
            sites.append(model.site(f"{w.name}_phone").id)
        else:
            sensors.append(None)
            sites.append(None)
    return World(
        scene=scene, spec=spec, model=model, data=data, person_body=body_ids, person_geom=geom_ids,
        geom_person=geom_person, qpos_adr=qpos_adr, qvel_adr=qvel_adr, phone_sensors=sensors,
        phone_site=sites, camera_ids={c.name: model.camera(c.name).id for c in scene.cameras},
    )
