"""What models keep between evaluations gives the numbers the direct computation gives, to the bit:
a point's map written out, a structure's spring ends shared by K, C and the base matrices, the
sensors' outputs shared by every model's rows, channel_swap's pairs named once per rig, the mass
matrix, its inverse and the sensors' rows shared by structures of the same bodies and flexible
modes."""

from __future__ import annotations

import numpy as np

from odsuite.analysis.prediction import _sensor_rows
from odsuite.domain.model import Output, Structure, point_map, skew


def test_point_map_is_identity_beside_minus_skew_to_the_bit():
    for r in ([0.1, -0.25, 3e-3], [0.0, -0.0, 1.0], [-1e-300, 2.5, -0.0]):
        want = np.hstack([np.eye(3), -skew(np.asarray(r, float))])
        got = point_map(r)
        assert got.shape == (3, 6)
        assert want.tobytes() == got.tobytes()  # signs of zero too


def _fresh(st: Structure) -> Structure:
    return Structure(st.bodies, st.springs, st.flexible_modes)


def test_kept_spring_ends_assemble_what_fresh_ones_do(registries, thesis_rig):
    model = registries.models.get("rigid-bodies")(thesis_rig)
    st = model.structure
    assert len(st.springs) > 1
    K, C = st.K, st.C  # the second of them from the ends the first kept
    kg, cg = st.base_matrices()

    def unkept(s):
        # the ends as computed before they were kept: a new structure for each spring
        return _fresh(st)._new_spring_ends(s)

    k = np.zeros_like(K)
    c = np.zeros_like(C)
    for s in st.springs:
        P, R = unkept(s)
        k += P.T @ s.matrix("stiffness") @ P + R.T @ s.matrix("rot_stiffness") @ R
        c += P.T @ s.matrix("damping") @ P + R.T @ s.matrix("rot_damping") @ R
    assert k.tobytes() == K.tobytes() and c.tobytes() == C.tobytes()
    kg2, cg2 = _fresh(st).base_matrices()
    assert kg.tobytes() == kg2.tobytes() and cg.tobytes() == cg2.tobytes()
    P, _ = st._spring_ends(st.springs[0])
    assert not P.flags.writeable  # shared between K, C and the base matrices


def test_kept_sensor_outputs_give_each_models_own_rows(registries, thesis_rig):
    model = registries.models.get("rigid-bodies")(thesis_rig)
    sensors = [s for s in thesis_rig.sensors if s.quantity == "acceleration"]
    stiff = registries.effects.get("stiffness")
    for m in (model, stiff.apply(model, {"scale_z": 1.3})):
        want = m.output_rows([Output.sensor(s) for s in sensors])[1]
        assert _sensor_rows(m, sensors).tobytes() == want.tobytes()
    other = sensors[::-1]  # another set of the same sensors: its own outputs
    assert _sensor_rows(model, other).tobytes() == model.output_rows([Output.sensor(s) for s in other])[1].tobytes()


def test_structures_of_the_same_bodies_share_what_follows_from_them(registries, thesis_rig, monkeypatch):
    import odsuite.domain.model as model_module

    model = registries.models.get("rigid-bodies")(thesis_rig)
    sensors = [s for s in thesis_rig.sensors if s.quantity == "acceleration"]
    outputs = [Output.sensor(s) for s in sensors]
    mass = registries.effects.get("mass_properties")
    nominal = {q.name: q.nominal for q in mass.parameters(model)}
    stiffer = registries.effects.get("stiffness").apply(model, {"scale_z": 1.3})
    heavier = mass.apply(model, {**nominal, **{k: 1.2 for k in nominal if k.endswith("mass_scale")}})
    moved = mass.apply(model, {**nominal, **{k: 0.01 for k in nominal if k.endswith("com_dz")}})
    st = model.structure
    rows, K = model.output_rows(outputs)[1], st.K
    # a stiffness change: the same bodies, M, M^-1, rows and the springs' ends
    other = stiffer.structure
    assert other.bodies is st.bodies and other.springs != st.springs and not np.array_equal(other.K, K)
    assert other.M is st.M and other.Minv is st.Minv and not st.M.flags.writeable
    assert other._unit_rows is st._unit_rows and other._ends is st._ends
    assert stiffer.output_rows(outputs)[1].tobytes() == rows.tobytes()
    # a mass change: its own M, the same centres of mass, rows and ends; a moved centre: its own
    assert heavier.structure.bodies is not st.bodies and not np.array_equal(heavier.structure.M, st.M)
    assert heavier.structure._unit_rows is st._unit_rows and heavier.structure._ends is st._ends
    assert moved.structure._unit_rows is not st._unit_rows and moved.structure._ends is not st._ends
    # the same numbers as structures that share nothing
    monkeypatch.setattr(model_module, "_frame", lambda bodies, modes: {})
    monkeypatch.setattr(model_module, "_geometry", lambda bodies, modes: ({}, {}))
    for m in (model, stiffer, heavier, moved):
        kept, alone = m.structure, _fresh(m.structure)
        assert alone._unit_rows is not st._unit_rows and alone.M is not kept.M
        for name in ("M", "Minv", "K", "C"):
            assert getattr(alone, name).tobytes() == getattr(kept, name).tobytes()
        assert (m.replace(structure=alone).output_rows(outputs)[1].tobytes()
                == m.output_rows(outputs)[1].tobytes())


def test_channel_swap_pairs_and_their_names_kept_per_rig(registries, thesis_rig):
    effect = registries.effects.get("channel_swap")
    sensors = tuple(s for s in thesis_rig.sensors if s.quantity == "acceleration")
    want = [(a.name, b.name) for i, a in enumerate(sensors) for b in sensors[i + 1:]
            if (a.kind, a.quantity) == (b.kind, b.quantity)]
    model = registries.models.get("rigid-bodies")(thesis_rig)
    assert effect.pairs(sensors) == want
    first, again = effect.parameters(model), effect.parameters(model)
    assert first[0].description == again[0].description == "the exchanged pair: 0 = none, " + ", ".join(
        f"{k + 1} = {a}/{b}" for k, (a, b) in enumerate(want))
    assert effect.pair(sensors, {"pair": float(len(want))}) == want[-1]
