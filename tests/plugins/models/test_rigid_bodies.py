"""The 'rigid-bodies' model built from a rig file's bodies and [[springs]], against closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from odsuite.domain.errors import ConfigError
from odsuite.domain.rig import rig_from_dict


def test_thesis_rig_file_gives_the_thesis_model_exactly(registries, thesis_rig):
    assert thesis_rig.default_model == "rigid-bodies"
    built = registries.models.get("rigid-bodies")(thesis_rig)
    thesis = registries.models.get("thesis-dynamometer")(thesis_rig)
    for a, b in ((built.M, thesis.M), (built.K, thesis.K), (built.C, thesis.C)):
        assert np.max(np.abs(a - b)) <= 1e-9 * np.max(np.abs(b))
    assert np.allclose(built.modes().frequency_hz, thesis.modes().frequency_hz, rtol=1e-9, atol=0)


def chain(k1=4.0e5, k2=2.5e5, m1=20.0, m2=12.0, **spring2) -> dict:
    """Two bodies moving along z only: m1 on k1 to the ground, m2 on k2 to m1."""
    def body(name, m, z):
        return {"name": name, "mass": m, "inertia": np.eye(3).tolist(), "com": [0, 0, z], "dofs": ["z"]}
    return {"name": "chain", "bodies": [body("base", m1, 0.0), body("machine", m2, -0.3)],
            "springs": [{"name": "isolator", "body": "base", "position": [0, 0, 0.1], "stiffness": [0, 0, k1]},
                        {"name": "mount", "body": "machine", "other": "base", "position": [0, 0, -0.15],
                         "stiffness": [0, 0, k2], **spring2}]}


def test_two_bodies_in_series_match_the_two_degree_of_freedom_closed_form(registries):
    k1, k2, m1, m2 = 4.0e5, 2.5e5, 20.0, 12.0
    rig = rig_from_dict(chain(k1, k2, m1, m2), registries.sensor_types)
    model = registries.models.get("rigid-bodies")(rig)
    # det(K - w^2 M) = 0 for K = [[k1 + k2, -k2], [-k2, k2]], M = diag(m1, m2)
    a, b, c = m1 * m2, -(m1 * k2 + m2 * (k1 + k2)), k1 * k2
    w2 = np.sort(np.roots([a, b, c]))
    assert np.allclose(model.modes().frequency_hz, np.sqrt(w2) / (2 * np.pi), rtol=1e-12)


def test_a_stiffness_matrix_acts_as_its_principal_stiffnesses(registries):
    """A point-like body (tiny inertia, translations only) on one spring with K = R diag(k) R^T:
    its modes are sqrt(k_i / m) / 2 pi whatever the rotation R."""
    k = np.array([1.0e5, 4.0e5, 9.0e5])
    c, s = np.cos(0.4), np.sin(0.4)
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    K = R @ np.diag(k) @ R.T
    data = {"name": "point", "bodies": [{"name": "m", "mass": 2.0, "inertia": np.eye(3).tolist(),
                                          "dofs": ["x", "y", "z"]}],
            "springs": [{"name": "s", "body": "m", "position": [0, 0, 0], "stiffness": ((K + K.T) / 2).tolist()}]}
    model = registries.models.get("rigid-bodies")(rig_from_dict(data, registries.sensor_types))
    assert np.allclose(model.modes().frequency_hz, np.sqrt(k / 2.0) / (2 * np.pi), rtol=1e-10)


@pytest.mark.parametrize("change, words", [
    (lambda d: d["springs"][0].update(body="frame"), ["springs[0] 'isolator'", "field 'body'", "'frame'"]),
    (lambda d: d["springs"][1].update(other="machine"), ["springs[1] 'mount'", "field 'other'", "itself"]),
    (lambda d: d["springs"][0].update(stiffness=[0, 0, -4e5]), ["springs[0] 'isolator'", "field 'stiffness'",
                                                                 "negative"]),
    (lambda d: d["springs"][0].update(stiffness=[0, 0, 0]), ["springs[0] 'isolator'", "field 'stiffness'", "zero"]),
    (lambda d: d["springs"][0].update(stiffness=[[1, 2, 0], [0, 1, 0], [0, 0, 1]]), ["field 'stiffness'",
                                                                                    "not symmetric"]),
    (lambda d: d["springs"][0].update(stiffness="stiff"), ["field 'stiffness'", "'stiff'"]),
    (lambda d: d["springs"][1].update(name="isolator"), ["two springs share a name"]),
    (lambda d: d["bodies"][0].pop("mass"), ["springs[0] 'isolator'", "field 'body'", "has no mass"]),
    (lambda d: d["bodies"][1].update(dofs=["z", "yaw"]), ["body 'machine'", "field 'dofs'", "'yaw'"]),
])
def test_bad_springs_are_one_line(registries, change, words):
    data = chain()
    change(data)
    with pytest.raises(ConfigError) as err:
        rig_from_dict(data, registries.sensor_types)
    msg = str(err.value)
    assert "\n" not in msg and all(w in msg for w in words), msg


def test_bodies_the_springs_do_not_hold_are_refused_by_the_model(registries):
    loose = chain()
    loose["springs"] = loose["springs"][:1]
    with pytest.raises(ConfigError, match=r"body 'machine' is held by no \[\[springs\]\] entry"):
        registries.models.get("rigid-bodies")(rig_from_dict(loose, registries.sensor_types))
    sideways = chain()
    sideways["bodies"][1]["dofs"] = ["x", "z"]  # nothing resists the machine's sliding along x
    with pytest.raises(ConfigError, match=r"do not resist the motion .*machine\.x"):
        registries.models.get("rigid-bodies")(rig_from_dict(sideways, registries.sensor_types))


def test_springs_too_soft_to_hold_anything_are_refused_by_the_model(registries):
    """Springs of 1e-9 N/m (the rig file refuses below 1e-12) pass the relative rank test (every
    coefficient is as small) but hold nothing: the motion's natural frequency, sqrt(k / m) / 2 pi,
    is named in the one line."""
    k, m1, m2 = 1e-9, 20.0, 12.0  # the chain's slowest mode from det(K - w^2 M) = 0, as above
    slowest = np.sqrt(np.sort(np.roots([m1 * m2, -(m1 * k + m2 * (k + k)), k * k]))[0]) / (2 * np.pi)
    with pytest.raises(ConfigError, match=r"hardly resist the motion 0\.68 base\.z \+ 1 machine\.z: its natural frequency is "
                       + f"{slowest:.3g}".replace(".", r"\.") + " Hz") as err:
        registries.models.get("rigid-bodies")(rig_from_dict(chain(k1=k, k2=k), registries.sensor_types))
    assert "\n" not in str(err.value)
    # just below and just above the limit (one body: f = sqrt(k / m) / 2 pi)
    m = 20.0
    for hz, refused in ((0.9e-3, True), (1.1e-3, False)):
        k = m * (2 * np.pi * hz) ** 2
        data = chain(k1=k, m1=m)
        data["bodies"] = data["bodies"][:1]
        data["springs"] = data["springs"][:1]
        build = lambda: registries.models.get("rigid-bodies")(rig_from_dict(data, registries.sensor_types))  # noqa: E731
        if refused:
            with pytest.raises(ConfigError, match=r"natural frequency is 0\.0009 Hz"):
                build()
        else:
            assert np.isclose(build().modes().frequency_hz[0], hz, rtol=1e-9)
