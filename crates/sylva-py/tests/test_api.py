"""The API of issue 42: presets, recipes (set, TOML, schema), grow, the skeleton as
numpy arrays, the report, previews and L-systems."""

import time

import numpy as np
import pytest

import sylva

TEXT = "Lsystem: 1\nderivation length: 3\nAxiom: F\nF --> F[+F]F[-F]F\nendlsystem\n"


def test_presets_list_the_tree_presets():
    names = sylva.presets()
    assert "wp-quaking-aspen" in names and "lsys-honda-a" in names
    assert names == sorted(names)
    assert not any(n.startswith("curves-") for n in names)
    assert sylva.preset_descriptions()["wp-quaking-aspen"]


def test_recipe_set_get_and_toml_round_trip():
    r = sylva.Recipe.preset("lsys-honda-a")
    assert r.name == "lsys-honda-a" and r.generator == "lsystem"
    assert r.set("mesh.sides", 6) is r
    assert r.get("mesh.sides") == 6
    r.set("leaves.mode", "geometry").set("refine.levels", 1)
    again = sylva.Recipe.from_toml(r.to_toml())
    assert again.to_toml() == r.to_toml()
    assert again.to_dict()["mesh"]["sides"] == 6
    c = r.copy()
    c.seed = 99
    assert r.seed != 99 and c.seed == 99


def test_a_bad_value_is_a_recipe_error_and_changes_nothing():
    r = sylva.Recipe.preset("lsys-honda-a")
    before = r.to_toml()
    with pytest.raises(sylva.RecipeError, match="mesh.sides"):
        r.set("mesh.sides", 2)
    with pytest.raises(sylva.RecipeError, match="sprites"):
        r.set("leaves.mode", "sprites")
    with pytest.raises(sylva.RecipeError):
        r.set("mesh.no_such_key", 1)
    with pytest.raises(sylva.RecipeError):
        r.set("mesh.sides", object())
    assert r.to_toml() == before
    with pytest.raises(sylva.RecipeError, match="unknown preset"):
        sylva.Recipe.preset("no-such-tree")
    assert issubclass(sylva.RecipeError, sylva.SylvaError)
    assert issubclass(sylva.LsystemError, sylva.SylvaError)


def test_a_toml_syntax_error_has_line_and_column():
    with pytest.raises(sylva.RecipeError) as e:
        sylva.Recipe.from_toml('preset = "lsys-honda-a"\n[mesh]\nsides = = 3\n')
    assert e.value.line == 3 and e.value.column is not None


def test_from_toml_over_a_preset_and_from_file(tmp_path):
    r = sylva.Recipe.from_toml('preset = "lsys-honda-a"\n[mesh]\nsides = 5\n')
    assert r.get("mesh.sides") == 5
    assert r.grow().triangles > 0
    path = tmp_path / "tree.l"
    path.write_text(TEXT)
    t = sylva.Recipe.from_file(path).grow()
    assert len(t.skeleton) > 1
    with pytest.raises(sylva.SylvaError):
        sylva.Recipe.from_file(tmp_path / "missing.l")


def test_schema_is_data():
    keys = {k["key"]: k for k in sylva.schema()}
    sides = keys["mesh.sides"]
    assert sides["kind"] == {"type": "integer", "min": 3, "max": 1024}
    assert sides["default"] == 8 and sides["doc"]
    assert keys["leaves.mode"]["kind"]["type"] == "mode"
    assert "geometry" in keys["leaves.mode"]["kind"]["values"]
    assert len(sylva.Recipe.schema()) == len(keys) or len(sylva.Recipe.schema()) > len(keys)


def test_skeleton_arrays(aspen):
    sk = aspen.skeleton
    n = len(sk)
    assert n > 100
    assert sk.positions.shape == (n, 3) and sk.positions.dtype == np.float32
    assert sk.parents.shape == (n,) and sk.parents.dtype == np.int32
    assert sk.radii.shape == (n,) and sk.radii.dtype == np.float32
    assert sk.order.shape == (n,) and sk.order.dtype == np.int32
    roots = np.flatnonzero(sk.parents == -1)
    assert len(roots) >= 1 and roots[0] == 0
    # Parent-first: every parent index is smaller than its child's.
    kids = np.flatnonzero(sk.parents >= 0)
    assert np.all(sk.parents[kids] < kids)
    assert sk.order.max() == aspen.report["max_order"]
    # Segment lengths add up to the report's total length.
    seg = np.linalg.norm(sk.positions[kids] - sk.positions[sk.parents[kids]], axis=1)
    assert abs(seg.sum() - aspen.report["total_length"]) < 1e-3 * aspen.report["total_length"]


def test_report_and_summary(aspen):
    r = aspen.report
    assert r["triangles"] == aspen.triangles > 0
    assert r["nodes"] == len(aspen.skeleton)
    assert "generate" in r["stage_times"]
    assert str(aspen).startswith("wp-quaking-aspen:")
    assert "triangles" in r["text"]
    assert aspen.recipe.name == "wp-quaking-aspen"


def test_seed_changes_the_tree_and_is_deterministic():
    r = sylva.Recipe.preset("lsys-abop-stochastic")
    a, b, c = r.grow(seed=1), r.grow(seed=1), r.grow(seed=2)
    assert a.to_glb() == b.to_glb()
    assert a.seed == 1 and c.seed == 2
    assert not np.array_equal(a.skeleton.positions, c.skeleton.positions)


def test_preview_is_a_png(aspen):
    png = aspen.preview(64)
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert aspen._repr_png_()[:4] == b"\x89PNG"
    assert aspen.preview(48, azimuth=90, elevation=10) != aspen.preview(48, azimuth=0, elevation=10)
    with pytest.raises(sylva.SylvaError):
        aspen.preview(0)


def test_lsystem_derive_and_turtle():
    assert sylva.lsystem.derive(TEXT, 1) == "F[+F]F[-F]F"
    assert sylva.lsystem.derive(TEXT, 0) == "F"
    three = sylva.lsystem.derive(TEXT)
    assert three.count("F") == 5**3
    sk = sylva.lsystem.skeleton(TEXT, 2)
    same = sylva.lsystem.interpret(sylva.lsystem.derive(TEXT, 2))
    np.testing.assert_allclose(sk.positions, same.positions, atol=1e-6)
    np.testing.assert_array_equal(sk.parents, same.parents)
    line = sylva.lsystem.interpret("F[+F]F")
    assert len(line) >= 4 and (line.parents == -1).sum() == 1
    wide = sylva.lsystem.interpret("F[+F]F", settings={"generator.angle": 60.0})
    assert not np.allclose(line.positions, wide.positions)


def test_lsystem_errors_carry_file_line_column():
    bad = "Lsystem: 1\nderivation length: 2\nAxiom: F\nF --> F[+F(\nendlsystem\n"
    with pytest.raises(sylva.LsystemError) as e:
        sylva.lsystem.derive(bad)
    err = e.value
    assert err.file == "model.l" and err.line == 4 and err.column >= 1, (err, err.line, err.column)
    assert isinstance(err, sylva.SylvaError)
    with pytest.raises(sylva.LsystemError) as e:
        sylva.Recipe.from_lsystem(bad).grow()
    assert (e.value.file, e.value.line) == ("model.l", 4)
    with pytest.raises(sylva.LsystemError) as e:
        sylva.lsystem.interpret("F(1)F(")
    assert e.value.line == 1 and e.value.column is not None


def test_other_errors_have_no_place(tmp_path):
    with pytest.raises(sylva.SylvaError) as e:
        sylva.Recipe.preset("lsys-honda-a").grow().save(tmp_path / "tree.xyz")
    assert e.value.file is None and e.value.line is None and e.value.column is None


def test_a_preset_recipe_written_as_toml_grows_the_same_tree(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = sylva.Recipe.preset("lsys-honda-a").set("mesh.sides", 5)
    again = sylva.Recipe.from_toml(r.to_toml())
    assert again.grow().to_glb() == r.grow().to_glb()


def test_timeout_stops_a_long_grow_with_timeout_error():
    # Honda's tree at 18 steps takes seconds; a 0.2 s timeout stops it at a checkpoint.
    recipe = sylva.Recipe.preset("lsys-honda-a").set("generator.iterations", 18)
    started = time.monotonic()
    with pytest.raises(TimeoutError, match="timeout=0.2"):
        recipe.grow(timeout=0.2)
    assert time.monotonic() - started < 30
    session = sylva.Session(recipe)
    with pytest.raises(TimeoutError):
        session.run(timeout=0.2)
    # A grow that fits its timeout is the same tree as one without.
    small = sylva.Recipe.preset("lsys-binary-tree")
    assert small.grow(timeout=60).to_glb() == small.grow().to_glb()
    assert sylva.Session(small).update(small, timeout=60).to_glb() == small.grow().to_glb()
    with pytest.raises(ValueError, match="timeout"):
        small.grow(timeout=0)
