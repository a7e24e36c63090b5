"""sylva.batch (issue 42 item 3): a Dask LocalCluster of two worker processes grows
20 trees byte-identical to the serial run, a failing tree is a manifest row, and the
package imports without dask.

The cluster tests need dask.distributed (skipped without it unless
SYLVA_REQUIRE_DASK=1, as in .ci/run)."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import sylva
import sylva.batch
from conftest import require

# 20 trees: small L-system presets over seeds, and one aspen.
JOBS = (
    [("lsys-binary-tree", s) for s in range(8)]
    + [("lsys-abop-stochastic", s) for s in range(6)]
    + [("lsys-honda-a", s) for s in (1, 2, 3)]
    + [("lsys-fern", 4), ("lsys-ternary-tree", 5)]
    + [("wp-quaking-aspen", 7)]
)

MODEL = "Lsystem: 1\nderivation length: 3\nAxiom: F\nF --> F[+F]F[-F]F\nendlsystem\n"


def missing_model_recipe() -> str:
    """A recipe that parses but cannot grow: its model file does not exist."""
    text = sylva.Recipe.preset("lsys-binary-tree").to_toml()
    assert 'file = "lsystem/binary-tree.l"' in text
    return text.replace('file = "lsystem/binary-tree.l"', 'file = "no-such-model.l"')


def manifest(path: Path) -> list:
    """The manifest's rows without their times (which differ between runs)."""
    rows = [json.loads(line) for line in path.read_text().splitlines()]
    for r in rows:
        assert r["seconds"] is not None and r["seconds"] >= 0
        del r["seconds"]
    return rows


def files(folder: Path) -> dict:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


@pytest.fixture(scope="module")
def client():
    """A LocalCluster of two worker processes, one thread each."""
    if require("SYLVA_REQUIRE_DASK"):
        import dask.distributed  # noqa: F401  (fails the test if missing)
    distributed = pytest.importorskip("dask.distributed")
    cluster = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    )
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    """The 20 trees (and one failing job) grown serially in this process."""
    out = tmp_path_factory.mktemp("serial")
    jobs = JOBS + [(missing_model_recipe(), 9)]
    result = sylva.batch.run(jobs, out, raise_on_error=False)
    return out, result


def test_local_cluster_is_byte_identical_to_the_serial_run(client, serial, tmp_path):
    serial_out, serial_result = serial
    jobs = JOBS + [(missing_model_recipe(), 9)]
    result = sylva.batch.run(jobs, tmp_path, client=client, raise_on_error=False)
    assert result.workers == 2
    assert len(result.rows) == 21 and [r["index"] for r in result.rows] == list(range(21))
    assert len(result.errors) == 1 and result.errors[0]["index"] == 20
    # Every file, byte for byte (20 trees and the manifest minus times); nothing else.
    a, b = files(serial_out), files(tmp_path)
    assert sorted(a) == sorted(b)
    assert len([n for n in a if n.endswith(".glb")]) == 20
    assert not [n for n in a if n.startswith(".")], "temporary files left behind"
    for name in a:
        if name != "manifest.jsonl":
            assert a[name] == b[name], name
    assert manifest(serial_out / "manifest.jsonl") == manifest(tmp_path / "manifest.jsonl")


def test_manifest_rows(serial):
    out, result = serial
    rows = manifest(out / "manifest.jsonl")
    assert [r["index"] for r in rows] == list(range(21))
    aspen = sylva.Recipe.preset("wp-quaking-aspen")
    import hashlib

    for r, (recipe, seed) in zip(rows[:20], JOBS):
        assert r["error"] is None
        assert r["seed"] == seed and r["recipe"] == recipe
        assert r["file"] == f"tree-{r['index']:05d}-{seed}.glb" and r["files"] == [r["file"]]
        data = (out / r["file"]).read_bytes()
        assert r["bytes"] == len(data) and r["sha256"] == hashlib.sha256(data).hexdigest()
        assert r["triangles"] > 0 and r["vertices"] > 0
    # The recipe hash is the SHA-256 of the canonical TOML.
    assert rows[19]["recipe_sha256"] == hashlib.sha256(aspen.to_toml().encode()).hexdigest()
    # The aspen grown directly gives the same file and counts.
    tree = aspen.grow(seed=7)
    assert tree.to_glb() == (out / rows[19]["file"]).read_bytes()
    assert rows[19]["triangles"] == tree.triangles


def test_a_failing_tree_is_a_row_and_the_summary_raises(serial, tmp_path):
    _, result = serial
    (bad,) = result.errors
    assert bad["index"] == 20 and bad["seed"] == 9 and bad["file"] is None
    assert "no-such-model.l" in bad["error"], bad["error"]
    assert all(r["error"] is None for r in result.rows[:20])
    jobs = [("lsys-binary-tree", 1), (missing_model_recipe(), 2), ("lsys-binary-tree", 3)]
    with pytest.raises(sylva.batch.BatchError, match="1 of 3 trees failed") as e:
        sylva.batch.run(jobs, tmp_path)
    # The raise comes after the other trees and the manifest are written.
    assert [r["error"] is None for r in e.value.result.rows] == [True, False, True]
    assert len((tmp_path / "manifest.jsonl").read_text().splitlines()) == 3
    assert (tmp_path / "tree-00002-3.glb").is_file()


def test_write_on_client_and_csv_manifest(client, serial, tmp_path):
    serial_out, _ = serial
    jobs = JOBS[:4]
    result = sylva.batch.run(
        jobs, tmp_path, client=client, write_on="client", manifest="manifest.csv"
    )
    assert not result.errors
    for r in result.rows:
        assert (tmp_path / r["file"]).read_bytes() == (serial_out / r["file"]).read_bytes()
    lines = (tmp_path / "manifest.csv").read_text().splitlines()
    assert lines[0].split(",") == list(sylva.batch.FIELDS) and len(lines) == 5


def test_model_file_travels_with_the_task(tmp_path):
    """A recipe read from a model file: the file's text is shipped with the task, so a
    worker without the folder grows the same tree."""
    model = tmp_path / "plant.l"
    model.write_text(MODEL)
    out = tmp_path / "out"
    result = sylva.batch.run([(model, 3)], out)
    (row,) = result.rows
    assert row["recipe"] == "plant" and row["model_sha256"] is not None
    resolved = sylva.batch._resolve(model, tmp_path)
    assert resolved["files"] == {"plant.l": MODEL.encode()}
    task = dict(resolved, index=0, seed=3, file="again.glb", out=None, threads=1)
    task["base_dir"] = str(tmp_path / "not-on-this-worker")
    again = sylva.batch._grow_one(task)
    assert again["error"] is None
    assert again["_data"]["again.glb"] == (out / row["file"]).read_bytes()


def test_an_output_folder_missing_on_the_worker_is_an_error_row(tmp_path):
    """A worker that does not see the output folder (no shared file system) says so."""
    task = dict(sylva.batch._resolve("lsys-binary-tree", tmp_path), index=0, seed=1)
    task.update(file="t.glb", out=str(tmp_path / "elsewhere"), threads=1)
    row = sylva.batch._grow_one(task)
    assert row["file"] is None and "write_on='client'" in row["error"], row["error"]
    assert "elsewhere" in row["error"]


def test_bad_batches_fail_before_growing(tmp_path):
    with pytest.raises(ValueError, match="both write"):
        sylva.batch.run(
            [("lsys-binary-tree", 1), ("lsys-binary-tree", 1)], tmp_path, name="tree-{seed}.{ext}"
        )
    with pytest.raises(sylva.RecipeError):
        sylva.batch.run([("no-such-preset", 1)], tmp_path)
    with pytest.raises(ValueError, match="plain file name"):
        sylva.batch.run([("lsys-binary-tree", 1)], tmp_path, name="a/{seed}.{ext}")
    with pytest.raises(ValueError, match="write_on"):
        sylva.batch.run([], tmp_path, write_on="nowhere")
    assert list(tmp_path.iterdir()) == []


def test_other_formats_write_their_companions(tmp_path):
    result = sylva.batch.run([("lsys-binary-tree", 1)], tmp_path, format="obj")
    (row,) = result.rows
    assert row["file"] == "tree-00000-1.obj" and row["files"][-1] == row["file"]
    assert "tree-00000-1.mtl" in row["files"]
    assert sorted(row["files"] + ["manifest.jsonl"]) == sorted(p.name for p in tmp_path.iterdir())
    assert row["bytes"] == sum((tmp_path / n).stat().st_size for n in row["files"])


def test_the_package_imports_without_dask(tmp_path):
    """With dask and distributed unimportable, `import sylva.batch` works and a serial
    batch runs; importing it does not import dask."""
    code = (
        "import sys\n"
        "sys.modules['dask'] = None\n"
        "sys.modules['distributed'] = None\n"
        "import sylva, sylva.batch\n"
        "assert not [m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed')"
        " and sys.modules[m] is not None]\n"
        f"r = sylva.batch.run([('lsys-binary-tree', 2)], {str(tmp_path)!r})\n"
        "print(r.rows[0]['file'])\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "tree-00000-2.glb"
    src = Path(sylva.batch.__file__).read_text()
    top = [ln for ln in src.splitlines() if ln.startswith(("import ", "from "))]
    assert not [ln for ln in top if "dask" in ln or "distributed" in ln], top


def test_command_line(tmp_path):
    out = tmp_path / "forest"
    cmd = [
        sys.executable,
        "-m",
        "sylva.batch",
        "--preset",
        "lsys-binary-tree",
        "--count",
        "3",
        "--first-seed",
        "10",
        "--out",
        str(out),
    ]
    done = subprocess.run(cmd, capture_output=True, text=True, env=dict(os.environ))
    assert done.returncode == 0, done.stderr
    assert "3 of 3 trees" in done.stdout
    rows = manifest(out / "manifest.jsonl")
    assert [r["file"] for r in rows] == [f"tree-0000{i}-{10 + i}.glb" for i in range(3)]
    bad = subprocess.run(
        [
            sys.executable,
            "-m",
            "sylva.batch",
            "--recipe",
            str(tmp_path / "none.toml"),
            "--count",
            "1",
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
    )
    assert bad.returncode != 0 and "none.toml" in bad.stderr
