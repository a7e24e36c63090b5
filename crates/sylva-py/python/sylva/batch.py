"""Forests in batch: grow a list of ``(recipe, seed)`` jobs, one file per tree plus a
manifest, serially or over a ``dask.distributed`` cluster (issue 42, docs/python.md).

Trees are independent given (recipe, seed), so a batch shards perfectly: each task
grows one tree and writes one file, and the result is byte-identical whichever
machine grew which tree::

    import sylva.batch
    jobs = [("lsys-honda-a", seed) for seed in range(1000)]
    sylva.batch.run(jobs, "forest")                    # serially, in this process

    from dask.distributed import Client, LocalCluster
    with Client(LocalCluster(n_workers=2, threads_per_worker=1)) as client:
        sylva.batch.run(jobs, "forest", client=client)  # the same files, in parallel

A task carries its recipe as TOML text (the engine's canonical ``Recipe.to_toml()``),
never a native object, so it pickles to any worker; the ``sylva`` package must be
installed on every worker. Files are written atomically (a temporary name in the
output folder, then a rename), and ``manifest.jsonl`` (or ``.csv``) lists every job
sorted by index. A tree that fails is a manifest row with its ``error``; after the
manifest is written, :class:`BatchError` is raised if any row has one (unless
``raise_on_error=False``).

Command line::

    python -m sylva.batch --preset wp-quaking-aspen --count 20 --out forest \\
        [--scheduler tcp://host:8786 | --local-workers 2]

``dask`` is imported only inside :func:`run` when a client is given (and by the
command line with ``--scheduler`` or ``--local-workers``): the package imports without it.
"""

import argparse
import csv
import hashlib
import io
import json
import os
import shutil
import socket
import sys
import tempfile
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, Iterable, List, Optional, Sequence, Tuple, Union

from . import _sylva

__all__ = ["BatchError", "BatchResult", "FIELDS", "main", "run"]

#: The manifest's columns, in order. ``recipe`` is the recipe's name, ``recipe_sha256``
#: the SHA-256 of its canonical TOML (what the task ships), ``model_sha256`` that of the
#: model file shipped with it (``None`` for the presets' embedded files), ``file`` the
#: tree's file in the output folder, ``files`` every file written for it (``.obj`` and
#: ``.pov`` write companions), ``bytes`` their total size, ``sha256`` the file's,
#: ``seconds`` the task's time (grow and write), ``error`` ``None`` or why it failed.
FIELDS: Tuple[str, ...] = (
    "index",
    "seed",
    "recipe",
    "recipe_sha256",
    "model_sha256",
    "file",
    "files",
    "triangles",
    "vertices",
    "bytes",
    "sha256",
    "seconds",
    "error",
)

RecipeLike = Union[str, "os.PathLike[str]", _sylva.Recipe]


class BatchError(Exception):
    """Raised by :func:`run` after the manifest is written when some trees failed;
    ``result`` is the whole :class:`BatchResult` (its ``errors`` are the failed rows)."""

    def __init__(self, result: "BatchResult"):
        self.result = result
        errors = result.errors
        head = "; ".join(f"#{r['index']} (seed {r['seed']}): {r['error']}" for r in errors[:3])
        more = f"; and {len(errors) - 3} more" if len(errors) > 3 else ""
        super().__init__(
            f"{len(errors)} of {len(result.rows)} trees failed (manifest {result.manifest}): "
            f"{head}{more}"
        )


@dataclass
class BatchResult:
    """What :func:`run` did: the manifest's ``rows`` (dicts with :data:`FIELDS`, sorted
    by index), the output folder, the manifest's path and the batch's wall time."""

    rows: List[Dict[str, Any]]
    out: Path
    manifest: Path
    seconds: float
    workers: int = field(default=1)

    @property
    def errors(self) -> List[Dict[str, Any]]:
        """The rows of the trees that failed."""
        return [r for r in self.rows if r["error"] is not None]

    @property
    def trees_per_second(self) -> float:
        """Trees grown and written per second of the batch's wall time."""
        ok = len(self.rows) - len(self.errors)
        return ok / self.seconds if self.seconds > 0 else float("inf")


def _sha256(data: Union[bytes, str]) -> str:
    if isinstance(data, str):
        data = data.encode("utf-8")
    return hashlib.sha256(data).hexdigest()


def _resolve(recipe: RecipeLike, base_dir: Path) -> Dict[str, Any]:
    """The shippable form of one job's recipe: canonical TOML, its name, hash, default
    seed, the folder its files resolve in and the model file's bytes (when on disk)."""
    if isinstance(recipe, _sylva.Recipe):
        r, where = recipe, base_dir
    elif isinstance(recipe, os.PathLike):
        path = Path(recipe).resolve()
        r, where = _sylva.Recipe.from_file(path), path.parent
    elif isinstance(recipe, str):
        if "\n" not in recipe and "=" not in recipe:
            r, where = _sylva.Recipe.preset(recipe), base_dir
        else:
            r, where = _sylva.Recipe.from_toml(recipe, base_dir), base_dir
    else:
        raise TypeError(
            "a batch job's recipe must be a preset name, TOML text, a path or a "
            f"sylva.Recipe, not {type(recipe).__name__}"
        )
    text = r.to_toml()
    files: Dict[str, bytes] = {}
    model = r.to_dict().get("generator", {}).get("file")
    if isinstance(model, str) and model and not Path(model).is_absolute():
        found = where / model
        if found.is_file():
            files[model] = found.read_bytes()
    return {
        "toml": text,
        "name": r.name,
        "recipe_sha256": _sha256(text),
        "model_sha256": _sha256(next(iter(files.values()))) if files else None,
        "seed": r.seed,
        "base_dir": str(where),
        "files": files,
    }


def _row(task: Dict[str, Any], **values: Any) -> Dict[str, Any]:
    row = {k: None for k in FIELDS}
    row.update(
        index=task["index"],
        seed=task["seed"],
        recipe=task["name"],
        recipe_sha256=task["recipe_sha256"],
        model_sha256=task["model_sha256"],
    )
    row.update(values)
    return row


def _load(task: Dict[str, Any], scratch: Path) -> _sylva.Recipe:
    """The task's recipe on the worker: its files from ``base_dir`` where that folder
    is there (a shared file system), else from the model file shipped with the task."""
    base = Path(task["base_dir"])
    if task["files"] and not all((base / n).is_file() for n in task["files"]):
        base = scratch / "model"
        for name, data in task["files"].items():
            target = base / name
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(data)
    return _sylva.Recipe.from_toml(task["toml"], base)


def _grow_one(task: Dict[str, Any]) -> Dict[str, Any]:
    """One task: grow the tree, save it under a temporary folder in the output folder,
    rename its files into place (companions first, the tree's file last). With no
    output folder (``write_on="client"``) the files' bytes come back in ``_data``.
    Never raises for a failing tree: the row carries the error."""
    start = time.perf_counter()
    out = Path(task["out"]) if task["out"] is not None else None
    if out is not None and not out.is_dir():
        return _row(
            task,
            seconds=time.perf_counter() - start,
            error=f"the output folder {out} is not on this worker ({socket.gethostname()}): "
            "use a folder every worker shares, or write_on='client'",
        )
    scratch = Path(tempfile.mkdtemp(prefix=f".{task['file']}.", dir=out))
    try:
        tree = _load(task, scratch).grow(seed=task["seed"], threads=task["threads"])
        made = scratch / "tree"
        made.mkdir()
        tree.save(made / task["file"])
        names = sorted(p.name for p in made.iterdir() if p.is_file())
        names.remove(task["file"])
        names.append(task["file"])
        data = {n: (made / n).read_bytes() for n in names}
        if out is not None:
            for n in names:
                os.replace(made / n, out / n)
        row = _row(
            task,
            file=task["file"],
            files=names,
            triangles=tree.triangles,
            vertices=tree.vertices,
            bytes=sum(len(d) for d in data.values()),
            sha256=_sha256(data[task["file"]]),
            seconds=time.perf_counter() - start,
        )
        if out is None:
            row["_data"] = data
        return row
    except Exception as e:  # a failing tree is a row, not a crashed batch
        return _row(task, seconds=time.perf_counter() - start, error=f"{type(e).__name__}: {e}")
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _write_atomic(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    try:
        tmp.write_bytes(data)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def _manifest_bytes(rows: Sequence[Dict[str, Any]], path: Path) -> bytes:
    if path.suffix.lower() == ".csv":
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(FIELDS)
        for r in rows:
            w.writerow(
                [
                    ";".join(r[k]) if k == "files" and r[k] else ("" if r[k] is None else r[k])
                    for k in FIELDS
                ]
            )
        return buf.getvalue().encode("utf-8")
    return "".join(json.dumps({k: r[k] for k in FIELDS}) + "\n" for r in rows).encode("utf-8")


def run(
    jobs: Iterable[Tuple[RecipeLike, Optional[int]]],
    out: Union[str, "os.PathLike[str]"],
    *,
    client: Any = None,
    format: str = "glb",
    name: str = "tree-{index:05d}-{seed}.{ext}",
    manifest: str = "manifest.jsonl",
    threads: Optional[int] = None,
    base_dir: Union[str, "os.PathLike[str]", None] = None,
    write_on: str = "worker",
    retries: int = 0,
    raise_on_error: bool = True,
) -> BatchResult:
    """Grow every ``(recipe, seed)`` of ``jobs`` and write one file per tree into the
    folder ``out`` (created if missing), then the manifest ``out/manifest``.

    - ``recipe``: a preset name, TOML text (file names in it resolve in ``base_dir``,
      default the current directory), a path to a recipe or model file, or a
      :class:`sylva.Recipe`; ``seed``: an int, or ``None`` for the recipe's own.
    - ``client``: a ``dask.distributed.Client`` (a ``LocalCluster``'s, or any
      cluster's), or ``None`` to grow serially in this process. The files and the
      manifest (but its ``seconds``) are byte-identical either way.
    - ``format``: the file format by extension (``glb``, ``gltf``, ``obj``, ``ply``,
      ``pov``, ``lst``, ``json``, ``png``); ``name``: the file name pattern, with
      ``{index}``, ``{seed}``, ``{recipe}`` (its name) and ``{ext}``.
    - ``manifest``: its file name in ``out``: JSON lines, or CSV if it ends in ``.csv``.
    - ``threads``: engine threads per tree (default: 1 on a cluster, where the workers'
      threads are the parallelism; the engine's pool of one thread per core serially).
    - ``write_on``: ``"worker"`` (each worker writes into ``out``, which must then be
      the same shared folder on every worker, e.g. NFS) or ``"client"`` (the files'
      bytes come back and this process writes them: no shared file system needed).
    - ``retries``: Dask's retries of a task whose worker died.
    - ``raise_on_error``: raise :class:`BatchError` (after writing the manifest) when
      some trees failed; with ``False`` the failed rows are only in the result.

    Raises ``ValueError`` (bad pattern, two jobs naming one file) and the recipe errors
    of a recipe that does not parse, before anything is grown."""
    if write_on not in ("worker", "client"):
        raise ValueError(f"write_on must be 'worker' or 'client', not {write_on!r}")
    ext = format.lstrip(".").lower()
    out_dir = Path(out).resolve()
    out_dir.mkdir(parents=True, exist_ok=True)
    base = Path(base_dir).resolve() if base_dir is not None else Path.cwd()
    cache: Dict[Any, Dict[str, Any]] = {}
    tasks: List[Dict[str, Any]] = []
    seen: Dict[str, int] = {}
    for index, job in enumerate(jobs):
        try:
            recipe, seed = job
        except (TypeError, ValueError):
            raise ValueError(
                f"batch job #{index} must be a (recipe, seed) pair, not {job!r}"
            ) from None
        key = recipe.to_toml() if isinstance(recipe, _sylva.Recipe) else recipe
        resolved = cache.get(key)
        if resolved is None:
            resolved = cache[key] = _resolve(recipe, base)
        seed = resolved["seed"] if seed is None else int(seed)
        try:
            file = name.format(index=index, seed=seed, recipe=resolved["name"], ext=ext)
        except (KeyError, IndexError, ValueError) as e:
            raise ValueError(
                f"file name pattern {name!r}: {e!r} (fields: index, seed, recipe, ext)"
            ) from None
        if not file or "/" in file or os.sep in file or file.startswith("."):
            raise ValueError(f"file name pattern {name!r} gives {file!r}: not a plain file name")
        if not file.lower().endswith("." + ext):
            raise ValueError(
                f"file name pattern {name!r} gives {file!r}, which does not end in .{ext}"
            )
        if file in seen:
            raise ValueError(f"jobs #{seen[file]} and #{index} both write {file!r}")
        seen[file] = index
        task = {
            k: resolved[k] for k in ("toml", "name", "recipe_sha256", "model_sha256", "base_dir")
        }
        task.update(
            files=resolved["files"],
            index=index,
            seed=seed,
            file=file,
            out=str(out_dir) if write_on == "worker" else None,
            threads=threads if threads is not None else (1 if client is not None else None),
        )
        tasks.append(task)

    start = time.perf_counter()
    rows: List[Dict[str, Any]] = []
    workers = 1

    def take(row: Dict[str, Any]) -> None:
        data = row.pop("_data", None)
        if data is not None:  # write_on="client": companions first, the tree's file last
            for n, d in data.items():
                _write_atomic(out_dir / n, d)
        rows.append(row)

    if client is None:
        for task in tasks:
            take(_grow_one(task))
    else:
        from dask.distributed import as_completed  # only here: sylva imports without dask

        workers = len(client.scheduler_info().get("workers", {})) or 1
        batch = uuid.uuid4().hex[:8]
        keys = [f"sylva-tree-{batch}-{t['index']}" for t in tasks]
        futures = client.map(_grow_one, tasks, key=keys, pure=False, retries=retries)
        by_key = {k: t for k, t in zip(keys, tasks)}
        for future in as_completed(futures):
            task = by_key[future.key]
            try:
                row = future.result()
            except Exception as e:  # the worker died, or the task could not run there
                row = _row(task, error=f"{type(e).__name__}: {e}")
            future.release()
            take(row)
    seconds = time.perf_counter() - start
    rows.sort(key=lambda r: r["index"])
    manifest_path = out_dir / manifest
    _write_atomic(manifest_path, _manifest_bytes(rows, manifest_path))
    result = BatchResult(rows, out_dir, manifest_path, seconds, workers)
    if raise_on_error and result.errors:
        raise BatchError(result)
    return result


def main(argv: Optional[Sequence[str]] = None) -> int:
    """``python -m sylva.batch``: grow ``--count`` trees of one recipe with seeds
    ``--first-seed`` onward into ``--out``; serially, on a new ``LocalCluster``
    (``--local-workers N``) or on a running scheduler (``--scheduler ADDRESS``).
    Prints a summary; returns 1 if some trees failed."""
    p = argparse.ArgumentParser(
        prog="python -m sylva.batch", description="Grow a forest: one file per tree + a manifest."
    )
    what = p.add_mutually_exclusive_group()
    what.add_argument("--preset", default=None, help="preset name (default wp-quaking-aspen)")
    what.add_argument("--recipe", type=Path, help="a recipe .toml or a model file (.l, …)")
    p.add_argument("--count", type=int, required=True, help="number of trees")
    p.add_argument("--first-seed", type=int, default=0, help="seed of the first tree (default 0)")
    p.add_argument("--out", type=Path, required=True, help="output folder")
    p.add_argument("--format", default="glb", help="file format by extension (default glb)")
    p.add_argument("--name", default="tree-{index:05d}-{seed}.{ext}", help="file name pattern")
    p.add_argument("--manifest", default="manifest.jsonl", help="manifest name (.jsonl or .csv)")
    p.add_argument("--threads", type=int, default=None, help="engine threads per tree")
    p.add_argument("--write-on", choices=("worker", "client"), default="worker")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--scheduler", help="address of a running Dask scheduler (tcp://host:8786)")
    where.add_argument("--local-workers", type=int, help="start a LocalCluster of N processes")
    a = p.parse_args(argv)
    if a.count < 0:
        p.error("--count must be ≥ 0")
    recipe: RecipeLike = a.recipe if a.recipe is not None else (a.preset or "wp-quaking-aspen")
    jobs = [(recipe, a.first_seed + i) for i in range(a.count)]
    kw: Dict[str, Any] = dict(
        format=a.format,
        name=a.name,
        manifest=a.manifest,
        threads=a.threads,
        write_on=a.write_on,
        raise_on_error=False,
    )
    try:
        result = _run_cli(a, jobs, kw)
    except (_sylva.SylvaError, ValueError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    ok = len(result.rows) - len(result.errors)
    print(
        f"{ok} of {len(result.rows)} trees in {result.seconds:.1f} s "
        f"({result.trees_per_second:.2f} trees/s, {result.workers} worker(s)); "
        f"manifest {result.manifest}"
    )
    for r in result.errors:
        print(f"  #{r['index']} seed {r['seed']}: {r['error']}", file=sys.stderr)
    return 1 if result.errors else 0


def _run_cli(a: argparse.Namespace, jobs: List[Any], kw: Dict[str, Any]) -> BatchResult:
    """The command line's batch: serial, on a new LocalCluster or on a scheduler."""
    if a.scheduler or a.local_workers:
        from dask.distributed import Client, LocalCluster

        if a.scheduler:
            client = Client(a.scheduler)
        else:
            cluster = LocalCluster(n_workers=a.local_workers, threads_per_worker=1, processes=True)
            client = Client(cluster)
        try:
            with client:
                return run(jobs, a.out, client=client, **kw)
        finally:
            if a.local_workers:
                cluster.close()
    return run(jobs, a.out, **kw)


if __name__ == "__main__":
    # Run the module's own copy (sylva.batch), not __main__'s: tasks must name
    # sylva.batch._grow_one, which a worker imports, rather than a __main__ function.
    from sylva.batch import main as _main

    sys.exit(_main())
