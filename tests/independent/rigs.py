"""Base structures for the cases: the thesis dynamometer (from the thesis digest's numbers) and a
two-body machine on a base frame on isolators. Both as a lab would describe them (nominal)."""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np

from .structure import (Accelerometer, Daq, ForceSensor, Hit, RigidBody, Spring,
                        Structure)


@dataclass
class RigBundle:
    name: str
    description: str
    frame: str
    structure: Structure
    accelerometers: list[Accelerometer]
    force_sensor: ForceSensor
    daq: Daq
    hits: list[Hit]  # the default set of hits, one record each
    spring_groups: dict[str, list[str]] = field(default_factory=dict)  # e.g. "isolators": [...]
    up: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))  # out of the top faces
    # the rig file's [processing] table (the chain of records without a .CTR); None: left out,
    # odsuite's default (the thesis's 20 Hz elliptic high-pass) applies
    processing: dict | None = None

    def copy(self) -> RigBundle:
        return copy.deepcopy(self)

    def accelerometer(self, name: str) -> Accelerometer:
        return next(a for a in self.accelerometers if a.name == name)


def box_inertia(mass: float, size) -> np.ndarray:
    """Inertia tensor of a uniform box about its centre (kg m^2)."""
    a, b, c = size
    return mass / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])


def thesis_rig() -> RigBundle:
    """Thesis digest section 1: platform on four 3-D springs, nine accelerometers on three corners,
    load cell on channel 0. Frame: origin at G, z down into the platform (the hammer's +z hits
    the top face)."""
    a, b, h = 0.02999, 0.04979, 0.01070  # App. B.2 spring offsets from G
    Iyz = 7.500541682e-5  # App. B.2 product of inertia; the tensor holds -Iyz
    inertia = np.array([[0.006187217392, 0.0, 0.0], [0.0, 0.002398407627, -Iyz], [0.0, -Iyz, 0.008366544210]])
    corner = np.array([-0.0500253, -0.08084058, -0.01139952])  # corner C = G - (lG, wG, hG), App. C
    rx, ry, rz = 0.09846, 0.16993, 0.02210  # Table E.3 rows 30-32
    platform = RigidBody(
        "platform", 2.714, np.zeros(3), inertia,
        plate={"size": [rx, ry, rz], "corner": corner.tolist()},
        nine_sensor_set={"corner": corner.tolist(), "rx": rx, "ry": ry, "rz": rz,
                         "sensors": {r: r for r in ("xC", "yC", "zC", "x1", "z1", "y2", "z2", "x3", "y3")}},
    )
    k = [262000.0, 262000.0, 1260000.0]  # N/m, App. B.2
    c = [140.0, 125.0, 275.0]  # N s/m, App. B.2
    springs = [Spring(f"spring{i + 1}", "platform", np.array(p), np.array(k), np.array(c))
               for i, p in enumerate([(-a, b, h), (a, b, h), (-a, -b, h), (a, -b, h)])]
    c1, c2, c3 = corner, corner + [0, ry, 0], corner + [rx, 0, 0]
    c4 = corner + [0, 0, rz]
    ex, ey, ez = np.eye(3)
    # (name, channel, position, axis, V/(m/s^2)): Fig. 4.9 layout, Table A.1 sensitivities
    layout = [("xC", 2, c1, ex, 0.020292), ("yC", 3, c1, ey, 0.020903), ("zC", 4, c1, ez, 0.021413),
              ("x1", 5, c2, ex, 0.020088), ("z1", 6, c2, ez, 0.020496), ("y2", 7, c3, ey, 0.020190),
              ("z2", 8, c3, ez, 0.020699), ("x3", 9, c4, ex, 0.020394), ("y3", 10, c4, ey, 0.019986)]
    # the thesis's accelerometers read negative along these axes (Table E.3 row 14 inverts them)
    accs = [Accelerometer(n, ch, "platform", np.array(p, float), ax.copy(), s, sign=-1.0)
            for n, ch, p, ax, s in layout]
    top = corner[2]
    hits = [
        Hit("platform", np.array([0.025, -0.040, top]), ez.copy(), 20.0, 0.4e-3),
        Hit("platform", np.array([corner[0], 0.030, 0.0]), ex.copy(), 20.0, 0.4e-3),
        Hit("platform", np.array([0.020, corner[1], 0.0]), ey.copy(), 20.0, 0.4e-3),
    ]
    return RigBundle(
        name="thesis-dynamometer",
        description="Thesis dynamometer model: platform on four 3-D springs, nine accelerometers, load cell",
        frame="origin at the platform's centre of mass G; x along the plate length, y along its width, z down",
        structure=Structure([platform], springs), accelerometers=accs,
        force_sensor=ForceSensor("force", 0, 2.248e-3),  # PCB 208B03, App. A
        daq=Daq(sampling_rate=20000.0, n_samples=4096, pre_trigger=256, aa_family="butter", aa_order=4,
                aa_cutoff_hz=1000.0),  # §5.1: 20 kHz, analog low-pass 1 kHz
        hits=hits, spring_groups={"springs": [s.name for s in springs]}, up=-ez,
    )


def two_body_rig() -> RigBundle:
    """A ~20 kg machine on four mounts on a ~40 kg base frame on four isolators to ground; three
    triaxial accelerometers per body, a load cell on channel 0. Frame: origin on the floor under
    the base's centre, z up."""
    base_size, machine_size = (0.8, 0.6, 0.1), (0.4, 0.3, 0.25)
    base = RigidBody("base", 40.0, np.array([0.0, 0.0, 0.05]), box_inertia(40.0, base_size),
                     plate={"size": list(base_size), "corner": [-0.4, -0.3, 0.0]})
    machine_com = np.array([0.02, 0.0, 0.225])  # slightly off the mounts' centre, as machines are
    machine = RigidBody("machine", 20.0, machine_com, box_inertia(20.0, machine_size),
                        plate={"size": list(machine_size), "corner": (machine_com - [0.2, 0.15, 0.125]).tolist()})
    springs = []
    for i, (sx, sy) in enumerate([(-1, -1), (1, -1), (1, 1), (-1, 1)]):
        # isolators: about 10-20 Hz for the whole machine; mounts: 40-100 Hz for the machine on the base
        springs.append(Spring(f"isolator{i + 1}", "base", np.array([0.35 * sx, 0.25 * sy, 0.0]),
                              np.array([8.0e4, 8.0e4, 2.0e5]), np.array([150.0, 150.0, 250.0])))
    for i, (sx, sy) in enumerate([(-1, -1), (1, -1), (1, 1), (-1, 1)]):
        springs.append(Spring(f"mount{i + 1}", "machine", np.array([0.15 * sx, 0.10 * sy, 0.1]),
                              np.array([6.0e5, 6.0e5, 1.5e6]), np.array([200.0, 200.0, 350.0]), other="base"))
    accs = []
    sens = 0.0102  # V/(m/s^2): 100 mV/g
    points = {"machine": [(-0.17, -0.12, 0.35), (0.19, -0.12, 0.35), (-0.17, 0.12, 0.35)],
              "base": [(-0.38, -0.28, 0.1), (0.38, -0.28, 0.1), (-0.38, 0.28, 0.1)]}
    channel = 1
    for body, pts in points.items():
        for j, p in enumerate(pts):
            housing = f"{body[0]}{j + 1}"
            for axis_name, axis in zip("xyz", np.eye(3)):
                # a 100 mV/g IEPE triaxial: mounted resonance ~22 kHz, 0.5 Hz AC coupling
                accs.append(Accelerometer(f"{housing}{axis_name}", channel, body, np.array(p), axis.copy(),
                                          sens, triaxial=housing, resonance_hz=22000.0, iepe_corner_hz=0.5))
                channel += 1
    ez = np.array([0.0, 0.0, 1.0])
    hits = [
        Hit("machine", np.array([0.12, 0.08, 0.35]), -ez, 100.0, 1.0e-3),
        Hit("machine", np.array([machine_com[0] + 0.2, -0.08, 0.30]), np.array([-1.0, 0.0, 0.0]), 100.0, 1.0e-3),
        Hit("base", np.array([0.25, -0.3, 0.07]), np.array([0.0, 1.0, 0.0]), 100.0, 1.0e-3),
    ]
    return RigBundle(
        name="two-body-machine",
        description="A machine on four mounts on a base frame on four isolators; three triaxial accelerometers per body",
        frame="origin on the floor under the base's centre; x along the base length, z up",
        structure=Structure([base, machine], springs), accelerometers=accs,
        force_sensor=ForceSensor("force", 0, 2.25e-3),
        daq=Daq(sampling_rate=10240.0, n_samples=8192, pre_trigger=512, aa_family="butter", aa_order=6,
                aa_cutoff_hz=2500.0),
        hits=hits, spring_groups={"isolators": [s.name for s in springs[:4]], "mounts": [s.name for s in springs[4:]]},
        up=ez,
    )


def plate_motor_rig() -> RigBundle:
    """A 37.7 kg steel plate (0.8 x 0.6 x 0.01 m, 7850 kg/m^3) on four rubber mounts at its corners
    (suspension modes 8.9-24 Hz), carrying an 8 kg motor (a 0.24 x 0.16 x 0.16 m box, off the plate's
    centre) on four stiff mounts (its modes on the plate 110-321 Hz). Two triaxial accelerometers and
    one z accelerometer per body (100 mV/g IEPE), an impact hammer with a soft tip (2.25 mV/N) on
    channel 0, a 24-bit DAQ at 5120 samples/s. Frame: origin on the floor under the plate's centre,
    x along the plate's length, z up. Written from the rig format's description alone."""
    plate_size, motor_size = (0.8, 0.6, 0.01), (0.24, 0.16, 0.16)
    plate_corner = np.array([-0.4, -0.3, 0.05])  # the mounts are 50 mm tall
    plate_com = plate_corner + np.array(plate_size) / 2
    plate = RigidBody("plate", 37.7, plate_com, box_inertia(37.7, plate_size),
                      plate={"size": list(plate_size), "corner": plate_corner.tolist()})
    motor_corner = np.array([0.0, -0.02, 0.08])  # 20 mm mounts on the plate's top face (z = 0.06 m)
    motor_com = motor_corner + np.array(motor_size) / 2
    motor = RigidBody("motor", 8.0, motor_com, box_inertia(8.0, motor_size),
                      plate={"size": list(motor_size), "corner": motor_corner.tolist()})
    springs = []
    for i, (sx, sy) in enumerate([(-1, -1), (1, -1), (1, 1), (-1, 1)]):
        # rubber: 3-4x stiffer in compression than in shear, about 5 % damping on its share of mass
        springs.append(Spring(f"rubber{i + 1}", "plate", np.array([0.35 * sx, 0.25 * sy, 0.05]),
                              np.array([3.7e4, 3.7e4, 1.0e5]), np.array([65.0, 65.0, 105.0])))
    for i, (sx, sy) in enumerate([(-1, -1), (1, -1), (1, 1), (-1, 1)]):
        springs.append(Spring(f"motor_mount{i + 1}", "motor",
                              np.array([motor_com[0] + 0.1 * sx, motor_com[1] + 0.06 * sy, 0.07]),
                              np.array([1.5e6, 1.5e6, 4.0e6]), np.array([100.0, 100.0, 170.0]), other="plate"))
    sens = 0.0102  # V/(m/s^2): 100 mV/g
    top_plate, top_motor = plate_corner[2] + plate_size[2], motor_corner[2] + motor_size[2]
    layout = {  # body: two triaxial points, then one z point off the line joining them
        "plate": [(-0.38, -0.28, top_plate), (0.38, 0.28, top_plate), (-0.38, 0.28, top_plate)],
        "motor": [(0.01, -0.01, top_motor), (0.23, 0.13, top_motor), (0.01, 0.13, top_motor)],
    }
    accs = []
    channel = 1
    for body, pts in layout.items():
        for j, p in enumerate(pts[:2]):
            housing = f"{body[0]}{j + 1}"
            for axis_name, axis in zip("xyz", np.eye(3)):
                accs.append(Accelerometer(f"{housing}_{axis_name}", channel, body, np.array(p), axis.copy(),
                                          sens, triaxial=housing, iepe_corner_hz=0.5))
                channel += 1
        accs.append(Accelerometer(f"{body[0]}3_z", channel, body, np.array(pts[2]), np.eye(3)[2].copy(), sens,
                                  iepe_corner_hz=0.5))
        channel += 1
    ez = np.array([0.0, 0.0, 1.0])
    hits = [
        Hit("plate", np.array([-0.20, 0.15, top_plate]), -ez, 10.0, 1.5e-3),
        Hit("motor", np.array([0.18, 0.02, top_motor]), -ez, 10.0, 1.5e-3),
        Hit("motor", np.array([motor_corner[0] + motor_size[0], 0.08, 0.15]), np.array([-1.0, 0.0, 0.0]), 10.0,
            1.5e-3),
        Hit("plate", np.array([-0.10, plate_corner[1], 0.055]), np.array([0.0, 1.0, 0.0]), 10.0, 1.5e-3),
    ]
    return RigBundle(
        name="plate-motor",
        description="An 8 kg motor on four stiff mounts on a 37.7 kg steel plate on four rubber mounts; "
                    "two triaxial and one z accelerometer per body",
        frame="origin on the floor under the plate's centre; x along the plate's length, y across, z up",
        structure=Structure([plate, motor], springs), accelerometers=accs,
        force_sensor=ForceSensor("hammer", 0, 2.25e-3),
        # 5120 samples/s: the anti-aliasing filter is -49 dB at the Nyquist frequency (at 2048 samples/s
        # with an 800 Hz filter a correct model left 1.7x the floor, its residual at 800-1024 Hz)
        daq=Daq(sampling_rate=5120.0, n_samples=4096, pre_trigger=256, adc_bits=24, aa_family="butter",
                aa_order=6, aa_cutoff_hz=1000.0),
        hits=hits, spring_groups={"rubber": [s.name for s in springs[:4]],
                                  "motor_mounts": [s.name for s in springs[4:]]},
        up=ez,
        # the suspension rings at 9-24 Hz: the default 20 Hz high-pass would remove it
        processing={"offset_samples": [0, 256],
                    "filter": {"family": "butterworth", "type": "highpass", "order": 2, "cutoff_hz": 1.0},
                    "filter_at": ["signal", "integral"]},
    )


RIGS = {"thesis": thesis_rig, "two-body": two_body_rig, "plate-motor": plate_motor_rig}


def _inclined(k_axial: float, k_shear: float, axis) -> np.ndarray:
    """3x3 stiffness (or damping) of a mount stiff along unit ``axis`` and soft across it."""
    n = np.asarray(axis, float) / np.linalg.norm(axis)
    return k_shear * np.eye(3) + (k_axial - k_shear) * np.outer(n, n)


def _one_hertz_highpass(pre_trigger: int) -> dict:
    """The [processing] table of a rig with modes below 20 Hz: offset from the pre-trigger samples,
    a 2nd-order 1 Hz Butterworth high-pass instead of the default 20 Hz elliptic."""
    return {"offset_samples": [0, pre_trigger],
            "filter": {"family": "butterworth", "type": "highpass", "order": 2, "cutoff_hz": 1.0},
            "filter_at": ["signal", "integral"]}


def cabinet_rig() -> RigBundle:
    """A tall steel cabinet (0.6 x 0.5 x 1.6 m, 70 kg, its centre of mass low and a little off
    centre) on four soft rubber mounts at its base corners, carrying a heavy 32 kg unit (a
    0.36 x 0.30 x 0.25 m box, off the roof's centre towards a corner) on three mounts inclined
    25 degrees inward (each 5x stiffer along its own axis than across: a full 3x3 stiffness in rig
    axes). Linear modes: rocking on the corner mounts 4.6 and 5.5 Hz, the rest of the suspension
    24-29 Hz, the unit on its mounts 124-307 Hz. Sensors of mixed sensitivity: on
    the cabinet a 1000 mV/g triaxial near the base, a 500 mV/g triaxial near the roof mounted on a
    wedge (its axes turned 30 degrees about z and 20 degrees about its own x), a 1000 mV/g y
    accelerometer at mid-height; on the unit a 100 mV/g triaxial and three 500 mV/g single axes,
    one of them mounted upside down (sign -1). The hammer (11.2 mV/N, a medium tip: 1 ms pulses,
    20 N by default) is channel 0; a 16-bit +-5 V DAQ at 3000 samples/s behind an 8th-order
    600 Hz Butterworth (-64 dB at the Nyquist frequency). Frame: origin on the floor under the cabinet's footprint centre, z up.
    Written from the rig format's description alone."""
    cab_size, unit_size = (0.6, 0.5, 1.6), (0.36, 0.30, 0.25)
    cab_corner = np.array([-0.3, -0.25, 0.04])  # 40 mm corner mounts
    # a cabinet is heavy at its base (the frame, a transformer): its centre of mass at 0.44 of its height
    cab_com = np.array([0.012, -0.008, cab_corner[2] + 0.44 * cab_size[2]])
    cabinet = RigidBody("cabinet", 70.0, cab_com, box_inertia(70.0, cab_size),
                        plate={"size": list(cab_size), "corner": cab_corner.tolist()})
    roof = cab_corner[2] + cab_size[2]
    unit_corner = np.array([-0.05, -0.22, roof + 0.03])  # towards the +x -y corner; 30 mm mounts
    unit_com = unit_corner + np.array(unit_size) / 2
    unit = RigidBody("unit", 32.0, unit_com, box_inertia(32.0, unit_size),
                     plate={"size": list(unit_size), "corner": unit_corner.tolist()})
    springs = []
    for i, (sx, sy) in enumerate([(-1, -1), (1, -1), (1, 1), (-1, 1)]):
        # rubber 3.5x stiffer in compression than in shear; 2 % damping in rocking, 5-10 % in the rest
        springs.append(Spring(f"foot{i + 1}", "cabinet", np.array([0.27 * sx, 0.22 * sy, 0.04]),
                              np.array([2.0e5, 2.0e5, 7.0e5]), np.array([150.0, 150.0, 900.0])))
    # three mounts under the unit at 120 degrees, each axis tilted 25 degrees towards the unit's centre
    for i, angle in enumerate(np.radians([90.0, 210.0, 330.0])):
        radial = np.array([np.cos(angle), np.sin(angle), 0.0])
        pos = np.array([unit_com[0], unit_com[1], roof + 0.015]) + 0.13 * radial
        axis = np.array([0.0, 0.0, 1.0]) * np.cos(np.radians(25)) - radial * np.sin(np.radians(25))
        springs.append(Spring(f"unit_mount{i + 1}", "unit", pos, _inclined(3.0e7, 6.0e6, axis),
                              _inclined(1500.0, 400.0, axis), other="cabinet"))
    g = 9.80665
    ex, ey, ez = np.eye(3)

    def turned(about_z_deg: float, about_x_deg: float) -> list[np.ndarray]:
        """The rig-axis unit vectors turned about z, then about the turned x axis."""
        cz, sz = np.cos(np.radians(about_z_deg)), np.sin(np.radians(about_z_deg))
        Rz = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
        cx, sx = np.cos(np.radians(about_x_deg)), np.sin(np.radians(about_x_deg))
        Rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
        R = Rz @ Rx
        return [R[:, k].copy() for k in range(3)]

    accs: list[Accelerometer] = []
    channel = 1

    def triaxial(housing, body, point, axes, sens):
        nonlocal channel
        for name, axis in zip("xyz", axes):
            accs.append(Accelerometer(f"{housing}_{name}", channel, body, np.array(point, float), axis,
                                      sens, triaxial=housing, iepe_corner_hz=0.3))
            channel += 1

    def single(name, body, point, axis, sens, sign=1.0):
        nonlocal channel
        accs.append(Accelerometer(name, channel, body, np.array(point, float), np.array(axis, float), sens,
                                  sign=sign, iepe_corner_hz=0.3))
        channel += 1

    triaxial("base", "cabinet", (-0.30, -0.25, 0.20), [ex, ey, ez], 1.0 / g)  # 1000 mV/g, on the -x face
    triaxial("top", "cabinet", (0.30, 0.25, 1.50), turned(30.0, 20.0), 0.5 / g)  # on a wedge, +x face
    single("mid_y", "cabinet", (-0.20, -0.25, 0.90), ey, 1.0 / g)  # on the -y face
    triaxial("unit", "unit", (unit_corner[0] + 0.02, unit_corner[1] + 0.02, unit_corner[2] + unit_size[2]),
             [ex, ey, ez], 0.1 / g)  # 100 mV/g
    unit_top = unit_corner[2] + unit_size[2]
    single("unit_z2", "unit", (unit_corner[0] + 0.34, unit_corner[1] + 0.02, unit_top), ez, 0.5 / g)
    # mounted upside down under a lip: its output is negative along +z
    single("unit_z3", "unit", (unit_corner[0] + 0.02, unit_corner[1] + 0.28, unit_top), ez, 0.5 / g, sign=-1.0)
    single("unit_y2", "unit", (unit_corner[0] + 0.34, unit_corner[1], unit_corner[2] + 0.15), ey, 0.5 / g)
    hits = [
        Hit("cabinet", np.array([cab_corner[0], 0.05, 1.40]), ex.copy(), 20.0, 1.0e-3),  # +x, high on the -x face
        Hit("cabinet", np.array([0.10, cab_corner[1] + cab_size[1], 0.50]), -ey, 20.0, 1.0e-3),  # -y, low
        Hit("unit", np.array([unit_corner[0] + 0.25, unit_corner[1] + 0.20, unit_top]), -ez, 20.0, 1.0e-3),
        Hit("unit", np.array([unit_corner[0] + unit_size[0], unit_corner[1] + 0.10, unit_corner[2] + 0.12]),
            -ex, 20.0, 1.0e-3),
    ]
    return RigBundle(
        name="tall-cabinet",
        description="A tall cabinet on four soft corner mounts with a heavy unit on three inclined mounts "
                    "off its roof's centre; sensors of mixed sensitivity, one triaxial on a wedge",
        frame="origin on the floor under the cabinet's footprint centre; x along its width, y its depth, z up",
        structure=Structure([cabinet, unit], springs), accelerometers=accs,
        force_sensor=ForceSensor("hammer", 0, 11.2e-3),
        daq=Daq(sampling_rate=3000.0, n_samples=4096, pre_trigger=256, adc_bits=16, adc_range=(-5.0, 5.0),
                aa_family="butter", aa_order=8, aa_cutoff_hz=600.0),
        hits=hits, spring_groups={"feet": [s.name for s in springs[:4]],
                                  "unit_mounts": [s.name for s in springs[4:]]},
        up=ez,
        # rocking at 5 Hz: the default 20 Hz high-pass would remove it
        processing=_one_hertz_highpass(256),
    )


RIGS["cabinet"] = cabinet_rig


def _tilted_axis(from_z_deg: float, towards) -> np.ndarray:
    """+z turned ``from_z_deg`` degrees towards the horizontal unit vector ``towards``."""
    t = np.radians(from_z_deg)
    h = np.asarray(towards, float) / np.linalg.norm(towards)
    return np.array([0.0, 0.0, np.cos(t)]) + np.sin(t) * h


def skid_rig() -> RigBundle:
    """A centrifugal pump and its motor on a welded steel skid: three rigid bodies. The skid (a
    1.4 x 0.7 x 0.16 m channel frame, 110 kg) stands on four rubber mounts at its corners, each
    inclined 40 degrees from the vertical towards the skid's long centre line (focal mounting, 5x
    stiffer in compression than in shear). The motor (75 kg, 0.50 x 0.30 x 0.32 m) and the pump
    (48 kg, its centre of mass towards its volute, off its box's centre) each sit on four stiff
    rubber pads on the skid (4x stiffer in compression). Linear modes 6.1-55 Hz. Sensors of mixed
    sensitivity: on the skid a 500 mV/g triaxial and three 1000 mV/g single axes (one pointing
    along -y); on the motor a 100 mV/g triaxial and three 1000 mV/g single axes; on the pump a
    500 mV/g triaxial, two 500 mV/g single axes and one 500 mV/g on the volute's sloping face (its
    axis 35 degrees from vertical, in neither the x-z nor the y-z plane). A 2.25 mV/N hammer with a soft tip (2 ms pulses) on
    channel 0; a 24-bit +-5 V DAQ at 2048 samples/s (51.2 kHz / 25) behind a 6th-order elliptic
    anti-aliasing filter at 700 Hz; IEPE coupling at 0.5 Hz. Frame: origin on the floor under the
    skid's centre, x along the skid from the motor to the pump, y across, z up.
    Written from the rig format's description alone."""
    g = 9.80665
    ex, ey, ez = np.eye(3)
    skid_size, skid_corner = (1.4, 0.7, 0.16), np.array([-0.7, -0.35, 0.10])  # 100 mm mounts
    skid_top = skid_corner[2] + skid_size[2]
    # a channel frame carries its steel at the rim: 1.3x the solid box's inertia
    skid = RigidBody("skid", 110.0, np.array([0.015, -0.01, 0.18]), 1.3 * box_inertia(110.0, skid_size),
                     plate={"size": list(skid_size), "corner": skid_corner.tolist()})
    motor_size, motor_corner = (0.50, 0.30, 0.32), np.array([-0.62, -0.15, skid_top + 0.02])
    motor = RigidBody("motor", 75.0, motor_corner + np.array(motor_size) / 2, box_inertia(75.0, motor_size),
                      plate={"size": list(motor_size), "corner": motor_corner.tolist()})
    pump_size, pump_corner = (0.46, 0.34, 0.36), np.array([0.08, -0.17, skid_top + 0.02])
    # the volute is the heavy part: centre of mass towards +x and a little off the shaft line
    pump_com = pump_corner + np.array([0.29, 0.19, 0.17])
    pump = RigidBody("pump", 48.0, pump_com, box_inertia(48.0, pump_size),
                     plate={"size": list(pump_size), "corner": pump_corner.tolist()})
    springs = []
    for i, (sx, sy) in enumerate([(-1, -1), (1, -1), (1, 1), (-1, 1)]):
        axis = _tilted_axis(40.0, [0.0, -sy, 0.0])
        springs.append(Spring(f"skid_mount{i + 1}", "skid", np.array([0.64 * sx, 0.31 * sy, 0.05]),
                              _inclined(5.0e5, 1.0e5, axis), _inclined(900.0, 200.0, axis)))
    for body, corner, size, k in (("motor", motor_corner, motor_size, 8.0e5), ("pump", pump_corner, pump_size, 6.0e5)):
        for i, (sx, sy) in enumerate([(-1, -1), (1, -1), (1, 1), (-1, 1)]):
            pos = np.array([corner[0] + size[0] * (0.5 + 0.42 * sx), corner[1] + size[1] * (0.5 + 0.45 * sy),
                            skid_top + 0.01])
            springs.append(Spring(f"{body}_pad{i + 1}", body, pos, np.array([k / 4, k / 4, k]),
                                  np.array([k / 4, k / 4, k]) * 2.5e-4, other="skid"))

    accs: list[Accelerometer] = []
    channel = 1

    def triaxial(housing, body, point, sens):
        nonlocal channel
        for name, axis in zip("xyz", (ex, ey, ez)):
            accs.append(Accelerometer(f"{housing}_{name}", channel, body, np.array(point, float), axis.copy(),
                                      sens, triaxial=housing, iepe_corner_hz=0.5))
            channel += 1

    def single(name, body, point, axis, sens):
        nonlocal channel
        accs.append(Accelerometer(name, channel, body, np.array(point, float), np.asarray(axis, float), sens,
                                  iepe_corner_hz=0.5))
        channel += 1

    triaxial("skid_a", "skid", (-0.66, -0.32, skid_top), 0.5 / g)
    single("skid_z2", "skid", (0.66, 0.32, skid_top), ez, 1.0 / g)
    single("skid_z3", "skid", (0.66, -0.32, skid_top), ez, 1.0 / g)
    single("skid_y2", "skid", (0.55, skid_corner[1], 0.18), -ey, 1.0 / g)  # on the -y face, pointing out
    motor_top = motor_corner[2] + motor_size[2]
    triaxial("motor_nde", "motor", (motor_corner[0] + 0.05, 0.0, motor_top), 0.1 / g)
    single("motor_de_z1", "motor", (motor_corner[0] + 0.45, 0.12, motor_top), ez, 1.0 / g)
    single("motor_de_z2", "motor", (motor_corner[0] + 0.45, -0.12, motor_top), ez, 1.0 / g)
    single("motor_de_y", "motor", (motor_corner[0] + 0.45, motor_corner[1] + 0.30, 0.50), ey, 1.0 / g)
    pump_top = pump_corner[2] + pump_size[2]
    triaxial("pump_brg", "pump", (pump_corner[0] + 0.06, pump_corner[1] + 0.17, pump_top), 0.5 / g)
    single("pump_volute", "pump", (pump_corner[0] + 0.40, pump_corner[1] + 0.28, pump_top - 0.03),
           _tilted_axis(35.0, [np.cos(np.radians(25.0)), np.sin(np.radians(25.0)), 0.0]), 0.5 / g)
    single("pump_z2", "pump", (pump_corner[0] + 0.40, pump_corner[1] + 0.04, pump_top), ez, 0.5 / g)
    single("pump_x", "pump", (pump_corner[0] + pump_size[0], pump_corner[1] + 0.08, 0.45), ex, 0.5 / g)
    hits = [
        Hit("skid", np.array([0.23, skid_corner[1], 0.21]), ey.copy(), 50.0, 2.0e-3),  # on the -y face
        Hit("motor", np.array([motor_corner[0] + 0.31, motor_corner[1] + 0.21, motor_top]), -ez, 50.0, 2.0e-3),
        Hit("pump", np.array([pump_corner[0] + pump_size[0], pump_corner[1] + 0.23, 0.39]), -ex, 50.0, 2.0e-3),
        Hit("skid", np.array([skid_corner[0], 0.12, 0.19]), ex.copy(), 50.0, 2.0e-3),  # the motor end
    ]
    return RigBundle(
        name="pump-skid",
        description="A pump and its motor on a welded skid on four inclined rubber mounts, each machine on "
                    "four pads; mixed sensitivities, one accelerometer on a sloping face",
        frame="origin on the floor under the skid's centre; x from the motor to the pump, y across, z up",
        structure=Structure([skid, motor, pump], springs), accelerometers=accs,
        force_sensor=ForceSensor("hammer", 0, 2.25e-3),
        daq=Daq(sampling_rate=2048.0, n_samples=2048, pre_trigger=128, adc_bits=24, adc_range=(-5.0, 5.0),
                aa_family="ellip", aa_order=6, aa_cutoff_hz=700.0),
        hits=hits, spring_groups={"skid_mounts": [s.name for s in springs[:4]],
                                  "motor_pads": [s.name for s in springs[4:8]],
                                  "pump_pads": [s.name for s in springs[8:]]},
        up=ez,
        # the lowest mode near 6 Hz: the default 20 Hz high-pass would remove it
        processing=_one_hertz_highpass(128),
    )


RIGS["skid"] = skid_rig


def gearbox_rig() -> RigBundle:
    """A stiffly mounted drive, two rigid bodies: a 17 kg cast-iron right-angle gearbox housing
    (0.32 x 0.24 x 0.22 m, its centre of mass low and a little off the box's centre, 0.85x a solid
    box's inertia for the gears near its middle) bolted to a machine bed through four thin bonded
    elastomer pads under its cast feet (15 mm with their steel plates; 40 MN/m in compression,
    14 MN/m in shear with the bolt sleeves), and a 5 kg servo motor (0.20 x 0.12 x 0.12 m)
    overhung from the gearbox's +x face on four elastomer flange bushings (80 MN/m along the
    motor's axis, 25 MN/m across). Linear modes 208-1560 Hz, 1.5-3.9 % damping: the assembly
    sliding on the pads' shear (across at 208 Hz, along at 221 Hz), the overhung motor bouncing at
    311 Hz, the housing swaying with a twist at 317 Hz, bouncing at 491 Hz, rolling, yawing and
    pitching at 742-1036 Hz, the motor on its bushings at 1451-1560 Hz. Sensors of
    mixed sensitivity, 1 Hz IEPE corner: on the gearbox a 100 mV/g triaxial, a 500 mV/g z and a
    100 mV/g y accelerometer and a 50 mV/g one on the cast chamfer of its -x top edge (its axis
    50 degrees from vertical, in neither the x-z nor the y-z plane); on the motor a 50 mV/g
    triaxial at its non-drive end, two 100 mV/g z at its flange end (one mounted upside down,
    sign -1) and a 10 mV/g one pointing along -y. A load-cell hammer with a hard steel tip
    (1.12 mV/N, 0.3 ms pulses, 50 N by default) on channel 0; a 24-bit +-10 V DAQ at 12800
    samples/s (51.2 kHz / 4) behind an 8th-order 2.5 kHz Butterworth anti-aliasing filter
    (-65 dB at the Nyquist frequency). The slowest mode is far above 20 Hz: the rig file keeps
    the default processing chain. Frame: origin on the machine bed's top face under the centre
    of the gearbox's footprint, x along the input shaft towards the motor, y across, z up.
    Written from the rig format's description alone."""
    g = 9.80665
    ex, ey, ez = np.eye(3)
    gb_size, gb_corner = (0.32, 0.24, 0.22), np.array([-0.16, -0.12, 0.015])  # on 15 mm pads
    gb_top = gb_corner[2] + gb_size[2]
    # the gear train sits low and towards the output side: centre of mass 25 mm below the box's centre
    gearbox = RigidBody("gearbox", 17.0, np.array([-0.015, 0.01, 0.10]), 0.85 * box_inertia(17.0, gb_size),
                        plate={"size": list(gb_size), "corner": gb_corner.tolist()})
    # the motor's flange 10 mm off the gearbox's +x face (the bushings between), its axis at the
    # input shaft's height (z = 0.13 m, y = 0.03 m); the stator makes it heavier towards the flange
    m_size, m_corner = (0.20, 0.12, 0.12), np.array([0.17, -0.03, 0.07])
    m_com = m_corner + np.array([0.085, 0.06, 0.06])
    motor = RigidBody("motor", 5.0, m_com, box_inertia(5.0, m_size),
                      plate={"size": list(m_size), "corner": m_corner.tolist()})
    springs = []
    for i, (sx, sy) in enumerate([(-1, -1), (1, -1), (1, 1), (-1, 1)]):
        # feet cast on the housing's sides (15 mm outside its width); 1.9-3.8 % damping in the modes below 400 Hz
        springs.append(Spring(f"pad{i + 1}", "gearbox", np.array([0.14 * sx, 0.135 * sy, 0.0075]),
                              np.array([1.4e7, 1.4e7, 4.0e7]), np.array([650.0, 650.0, 600.0])))
    for i, (sy, sz) in enumerate([(-1, -1), (1, -1), (1, 1), (-1, 1)]):
        # a square bolt pattern 90 mm across around the motor's axis, in the gap between the faces
        springs.append(Spring(f"bushing{i + 1}", "motor",
                              np.array([0.165, m_com[1] + 0.045 * sy, m_com[2] + 0.045 * sz]),
                              np.array([8.0e7, 2.5e7, 2.5e7]), np.array([200.0, 120.0, 120.0]), other="gearbox"))

    accs: list[Accelerometer] = []
    channel = 1

    def triaxial(housing, body, point, sens):
        nonlocal channel
        for name, axis in zip("xyz", (ex, ey, ez)):
            accs.append(Accelerometer(f"{housing}_{name}", channel, body, np.array(point, float), axis.copy(),
                                      sens, triaxial=housing, iepe_corner_hz=1.0))
            channel += 1

    def single(name, body, point, axis, sens, sign=1.0):
        nonlocal channel
        accs.append(Accelerometer(name, channel, body, np.array(point, float), np.asarray(axis, float), sens,
                                  sign=sign, iepe_corner_hz=1.0))
        channel += 1

    # gearbox: six independent directions spread over the housing (the smallest singular value of
    # the sensors' rigid-body map 0.136 m/rad, as the other rigs' bodies of its size)
    triaxial("gb", "gearbox", (0.13, -0.10, gb_top), 0.1 / g)  # top, at the +x -y corner
    single("gb_z2", "gearbox", (0.13, 0.10, gb_top), ez, 0.5 / g)
    single("gb_y2", "gearbox", (-0.12, gb_corner[1] + gb_size[1], 0.20), ey, 0.1 / g)  # on the +y face
    # on the chamfer of the -x top edge: 50 degrees from vertical towards -x, turned 20 degrees towards +y
    single("gb_chamfer", "gearbox", (gb_corner[0], 0.0, gb_top - 0.02),
           _tilted_axis(50.0, [-np.cos(np.radians(20.0)), np.sin(np.radians(20.0)), 0.0]), 0.05 / g)
    m_top = m_corner[2] + m_size[2]
    triaxial("mot", "motor", (m_corner[0] + 0.18, m_com[1], m_top), 0.05 / g)  # at the non-drive end
    single("mot_z2", "motor", (m_corner[0] + 0.02, m_com[1] + 0.055, m_top), ez, 0.1 / g)
    # mounted upside down on a bracket under the flange: its output is negative along +z
    single("mot_z3", "motor", (m_corner[0] + 0.02, m_com[1] - 0.055, m_corner[2]), ez, 0.1 / g, sign=-1.0)
    # a 10 mV/g shock accelerometer on the -y face, pointing out
    single("mot_y2", "motor", (m_corner[0] + 0.03, m_corner[1], m_top - 0.02), -ey, 0.01 / g)
    hits = [
        Hit("gearbox", np.array([-0.06, 0.05, gb_top]), -ez, 50.0, 0.3e-3),  # down on the top
        Hit("gearbox", np.array([0.04, gb_corner[1], 0.14]), ey.copy(), 50.0, 0.3e-3),  # +y on the -y face
        Hit("motor", np.array([m_corner[0] + m_size[0], m_com[1] + 0.01, 0.14]), -ex, 50.0, 0.3e-3),  # its end
        Hit("motor", np.array([m_corner[0] + 0.13, m_corner[1] + 0.02, m_top]), -ez, 50.0, 0.3e-3),  # off its axis
    ]
    return RigBundle(
        name="bed-gearbox",
        description="A cast gearbox bolted to a machine bed through four stiff elastomer pads, a servo motor "
                    "overhung on four flange bushings; mixed sensitivities, one accelerometer on a chamfer",
        frame="origin on the machine bed's top under the gearbox's footprint centre; x along the input shaft "
              "towards the motor, y across, z up",
        structure=Structure([gearbox, motor], springs), accelerometers=accs,
        force_sensor=ForceSensor("hammer", 0, 1.12e-3),
        daq=Daq(sampling_rate=12800.0, n_samples=4096, pre_trigger=256, adc_bits=24, adc_range=(-10.0, 10.0),
                aa_family="butter", aa_order=8, aa_cutoff_hz=2500.0),
        hits=hits, spring_groups={"pads": [s.name for s in springs[:4]],
                                  "bushings": [s.name for s in springs[4:]]},
        up=ez,
    )


RIGS["gearbox"] = gearbox_rig
