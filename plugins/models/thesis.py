"""The thesis's models: the dynamometer (Ch. 3, App. B, App. C) and the 2-DOF automobile (§2.1)."""

from __future__ import annotations

import numpy as np

from odsuite.api import ConfigError
from odsuite.api import Model, RigidBody, SpringDamper
from odsuite.api import Rig

#: App. B.2, SI. Springs 1..4 at (-a,+b,+h), (+a,+b,+h), (-a,-b,+h), (+a,-b,+h) from G: the sign
#: pattern App. B's k matrix implies.
APP_B = {
    "mass": 2.714,
    "Ixx": 0.006187217392, "Iyy": 0.002398407627, "Izz": 0.008366544210,
    "Ixy": 0.0, "Iyz": 0.00007500541682, "Ixz": 0.0,
    "kx": 262e3, "ky": 262e3, "kz": 1260e3,
    "cx": 140.0, "cy": 125.0, "cz": 275.0,
    "a": 0.02999, "b": 0.04979, "h": 0.01070,
}
SPRING_SIGNS = ((-1, 1, 1), (1, 1, 1), (-1, -1, 1), (1, -1, 1))
#: App. C listing: inertia in in^5 times steel density 7841 kg/m^3
APP_C_UNIT = 0.0254**5 * 7841.0
APP_C_PRODUCTS = {"Ixy": -0.05 * APP_C_UNIT, "Iyz": 0.9048 * APP_C_UNIT, "Ixz": -0.9 * APP_C_UNIT}


def inertia_tensor(Ixx: float, Iyy: float, Izz: float, Ixy: float, Iyz: float, Ixz: float) -> np.ndarray:
    """The inertia tensor from moments and products (App. B's m has -Ixy, -Iyz, -Ixz off the diagonal)."""
    return np.array([[Ixx, -Ixy, -Ixz], [-Ixy, Iyy, -Iyz], [-Ixz, -Iyz, Izz]])


def dynamometer_springs(a: float, b: float, h: float, k, c, body: str = "platform",
                        centre=(0.0, 0.0, 0.0)) -> list[SpringDamper]:
    """Springs 1..4 between ``body`` and the ground; ``k``, ``c`` per axis (3,) or per spring (4, 3)."""
    centre = np.asarray(centre, float)
    k = np.broadcast_to(np.asarray(k, float), (4, 3))
    c = np.broadcast_to(np.asarray(c, float), (4, 3))
    return [SpringDamper(f"spring{i + 1}", centre + np.array(sg) * (a, b, h), body, None, k[i], c[i])
            for i, sg in enumerate(SPRING_SIGNS)]


def thesis_dynamometer(rig: Rig | None = None, *, inertia_products: str = "app-b") -> Model:
    """The thesis dynamometer: the rig's platform (App. B mass and inertia in the thesis rig file) on
    four 3-D spring-dampers (App. B.2), built from geometry.

    ``inertia_products="app-c"`` replaces Ixy, Iyz, Ixz by App. C's listing
    (-0.05, 0.9048, -0.9 times 0.0254^5 * 7841 kg m^2); the moments stay App. B's.
    """
    p = APP_B
    if rig is not None:
        moving = rig.moving_bodies
        if not moving:
            raise ConfigError(f"rig {rig.name!r}: no body with a mass for the dynamometer model")
        platform = next((b for b in moving if b.name == "platform"), moving[0])
        body = RigidBody.from_rig(platform)
    else:
        body = RigidBody("platform", p["mass"], inertia_tensor(*(p[n] for n in ("Ixx", "Iyy", "Izz", "Ixy", "Iyz", "Ixz"))))
    if inertia_products == "app-c":
        I = body.inertia
        body = RigidBody(body.name, body.mass,
                         inertia_tensor(I[0, 0], I[1, 1], I[2, 2], **APP_C_PRODUCTS), body.com)
    elif inertia_products != "app-b":
        raise ConfigError(f"thesis-dynamometer option 'inertia_products': expected 'app-b' or 'app-c', got {inertia_products!r}")
    k = np.array([p["kx"], p["ky"], p["kz"]])
    c = np.array([p["cx"], p["cy"], p["cz"]])
    springs = dynamometer_springs(p["a"], p["b"], p["h"], k, c, body.name, body.com)
    return Model.build([body], springs, name="thesis-dynamometer",
                       info={"inertia_products": inertia_products, "source": "thesis App. B.2"}, rig=rig)


# §2.1 (Thomson): m = 3220 lb, J = 51 520 lb ft^2, k1 = 2400 lb/ft at l1 = 4.5 ft (front),
# k2 = 2600 lb/ft at l2 = 5.5 ft (rear); in slug units m = 100 slug, J = 1600 slug ft^2.
FT = 0.3048
SLUG = 14.59390294
LBF_PER_FT = 14.59390294  # lbf/ft in N/m (1 lbf/ft = 1 slug/s^2)
CAR = {"mass": 100 * SLUG, "J": 1600 * SLUG * FT**2, "k1": 2400 * LBF_PER_FT, "k2": 2600 * LBF_PER_FT,
       "l1": 4.5 * FT, "l2": 5.5 * FT}


def thesis_car_2dof(rig: Rig | None = None) -> Model:
    """The 2-DOF automobile of thesis §2.1: bounce z and pitch phi (about y) of a body on a front
    spring at x = +l1 and a rear spring at x = -l2 (SI; x forward, z up, so phi > 0 is nose down).
    The rig is ignored."""
    c = CAR
    # only J about y matters: the other moments keep the tensor positive definite
    body = RigidBody("car", c["mass"], np.diag([c["J"], c["J"], c["J"]]), dofs=("z", "phi"))
    springs = [SpringDamper("front", (c["l1"], 0.0, 0.0), "car", None, (0.0, 0.0, c["k1"])),
               SpringDamper("rear", (-c["l2"], 0.0, 0.0), "car", None, (0.0, 0.0, c["k2"]))]
    return Model.build([body], springs, name="thesis-car-2dof", info={"source": "thesis §2.1 (Thomson)"})
