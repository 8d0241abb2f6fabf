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


def _moved(effect, model, share: float = 0.3) -> dict[str, float]:
    """Every continuous parameter of ``effect`` a share of the way from its nominal to a bound."""
    out = {}
    for p in effect.parameters(model):
        if p.choices is None:
            out[p.name] = p.nominal + share * ((p.upper if p.upper > p.nominal else p.lower) - p.nominal)
    return out


def test_rows_and_force_columns_kept_for_a_geometry_and_chain_are_a_fresh_models(registries, thesis_rig):
    """A model's sensor rows and force columns are kept with its structure's geometry and chain
    (Model._on_geometry): a stiffness change takes its base's; a moved sensor, tilted axis,
    exchanged cable, moved centre of mass or force gain its own, equal to the bit to those of a
    model that keeps nothing (and different from the base's, so a stale entry would show)."""
    from odsuite.analysis.prediction import _sensor_outputs
    from odsuite.domain.model import Input, Model

    model = registries.models.get("rigid-bodies")(thesis_rig)
    sensors = [s for s in thesis_rig.sensors if s.quantity == "acceleration"]
    outputs = _sensor_outputs(sensors)
    inputs = [Input.force([0.05, -0.02, 0.1], [0.3, 0.2, -1.0], body=model.bodies[0].name)]
    rows, (bf, _) = model.output_rows(outputs)[1], model.input_matrices(inputs)
    stiffer = registries.effects.get("stiffness").apply(model, {"scale_z": 1.3, "scale_x": 0.7})
    assert stiffer.output_rows(outputs)[1] is rows and stiffer.input_matrices(inputs)[0] is bf  # kept
    assert not rows.flags.writeable and not bf.flags.writeable
    delayed = registries.effects.get("channel_delay")
    delayed = delayed.apply(model, _moved(delayed, model))
    assert delayed.chain.delay and delayed.output_rows(outputs)[1] is rows  # a delay moves no row
    changed = {name: registries.effects.get(name).apply(model, _moved(registries.effects.get(name), model))
               for name in ("sensor_position", "sensor_orientation", "sensor_gain", "mass_properties", "force_gain")}
    changed["channel_swap"] = registries.effects.get("channel_swap").apply(model, {"pair": 1.0})
    for name, m in {"base": model, "stiffness": stiffer, **changed}.items():
        for _ in range(2):  # computed, then kept
            got_rows, (got_bf, _) = m.output_rows(outputs)[1], m.input_matrices(inputs)
            fresh = Model(_fresh(m.structure), m.chain, rig=m.rig)  # a geometry of its own ...
            fresh.structure.__dict__["_unit_rows"] = {}  # ... that keeps nothing yet
            assert got_rows.tobytes() == fresh._output_rows(list(outputs)).tobytes(), name
            assert got_bf.tobytes() == fresh._input_matrices(list(inputs))[0].tobytes(), name
        moves_rows = name not in ("base", "stiffness", "force_gain")
        assert moves_rows == (got_rows.tobytes() != rows.tobytes()), name
        assert (name in ("mass_properties", "force_gain")) == (got_bf.tobytes() != bf.tobytes()), name
    # a base input reads the springs: never kept with the geometry
    base = [Input.base_translation([0.0, 0.0, 1.0])]
    assert stiffer.input_matrices(base)[0].tobytes() != model.input_matrices(base)[0].tobytes()


def test_effect_values_kept_per_model_check_as_the_parameters_declare(registries, thesis_rig):
    """Effect.values reads each parameter's nominal and bounds kept per model and effect: the
    values, the refusals, and another model's own parameters as ``parameters`` gives them."""
    import pytest

    from odsuite.domain.errors import ConfigError

    model = registries.models.get("rigid-bodies")(thesis_rig)
    stiff, swap = registries.effects.get("stiffness"), registries.effects.get("channel_swap")
    for effect in (stiff, swap):
        for _ in range(2):
            assert effect.values(model) == {p.name: float(p.nominal) for p in effect.parameters(model)}
    assert stiff.values(model, {"scale_z": 2.0})["scale_z"] == 2.0
    with pytest.raises(ConfigError, match=r"parameter .scale_z.: expected 0.25 to 4, got 100.0$"):
        stiff.values(model, {"scale_z": 100.0})
    with pytest.raises(ConfigError, match="unknown"):
        stiff.values(model, {"scale_q": 1.0})
    with pytest.raises(ConfigError, match="expected one of"):
        swap.values(model, {"pair": 0.5})
    # a model of one body fewer springs has fewer parameters: its own, not the first model's
    fewer = model.replace(structure=Structure(model.bodies, model.springs[:1], model.structure.flexible_modes))
    assert set(stiff.values(fewer)) == {p.name for p in stiff.parameters(fewer)} != set(stiff.values(model))


def test_assembled_stiffness_and_damping_kept_for_the_same_coefficients(registries, thesis_rig, monkeypatch):
    """K and C are kept with a geometry's spring ends for the same springs' coefficients: a
    stiffness change takes its base's C, a damping change its K, each equal to the bit to a
    structure's that keeps nothing; a moved spring or changed coefficient assembles its own."""
    from dataclasses import replace

    import odsuite.domain.model as model_module

    model = registries.models.get("rigid-bodies")(thesis_rig)
    st = model.structure
    stiffer = registries.effects.get("stiffness").apply(model, {"scale_z": 1.3}).structure
    damper = registries.effects.get("damping").apply(model, {"scale_x": 2.0}).structure
    moved = Structure(st.bodies, (replace(st.springs[0], point=st.springs[0].point + 0.01),) + st.springs[1:],
                      st.flexible_modes)
    assert stiffer.C is st.C and damper.K is st.K and not st.K.flags.writeable
    assert stiffer.K is not st.K and damper.C is not st.C and moved.K is not st.K and moved.C is not st.C
    want = {}
    monkeypatch.setattr(model_module, "_geometry", lambda bodies, modes: ({}, {}))
    for name, s in (("base", st), ("stiffer", stiffer), ("damper", damper), ("moved", moved)):
        alone = _fresh(s)
        want[name] = (alone.K, alone.C)
        assert alone.K.tobytes() == s.K.tobytes() and alone.C.tobytes() == s.C.tobytes(), name
    assert want["stiffer"][0].tobytes() != want["base"][0].tobytes()
    assert want["damper"][1].tobytes() != want["base"][1].tobytes()
    assert want["moved"][0].tobytes() != want["base"][0].tobytes()
