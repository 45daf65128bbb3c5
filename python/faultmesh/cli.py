"""The ``faultmesh`` command line (also ``python -m faultmesh``).

Every sub-command reports errors as one line on stderr and exits with status 2
(``--debug`` shows the traceback instead). See ``docs/cli.md``.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

EXIT_ERROR = 2

# The paper's two demonstration cuts (Gao et al. 2025, section 3.2, Figure 7).
PAPER_AZIMUTHS = (317.089497, 18.146639)

MAIN_EPILOG = """\
examples:
  faultmesh demo -o demo_out                 build the built-in paper-like model and
                                             write model files, report and pictures
  faultmesh build site/dataset.json -o out   build a model from your own dataset
  faultmesh build paper_like -o out --loft shortest_diagonal
  faultmesh derive site/dataset.json -o derived
                                             fault cutoffs, tips and kind from the data:
                                             derived dataset.json, cutoffs.pl
  faultmesh section out/site.3dt --origin 4500 3200 --azimuth 90 -o cut.csv --png cut.png
  faultmesh quality out/site.3dt --json quality.json
  faultmesh convert out/site.3dt site.ml     (GOCAD Model3d; also .ts .vtu .vtk .vtp
                                             .obj .ply .omf .epc .geoh5)
  faultmesh plot out/site.3dt --png model.png
  faultmesh ensemble paper_like -n 200 -o ens --sigma-z 2 --sigma-position 15
                                             200 perturbed realizations on Dask: mean,
                                             std, P10/P50/P90 maps and section fans

Datasets: a JSON file of format v1 or v2 (docs/dataset.md) or a built-in name
(paper_like, synthetic). Models: .3dt (faultmesh's own, keeps everything),
.ts, .ml, .vtu, .vtp, .vtk, .obj, .ply, .omf, .epc (RESQML), .geoh5, read also
.pl and .stl, or a folder written by 'build' (docs/formats.md).
Azimuths are degrees clockwise from north (0 = north, 90 = east).
"""


class CliError(Exception):
    """An error worth one line on stderr (no traceback)."""


# ----------------------------------------------------------------------------
# helpers
# ----------------------------------------------------------------------------

def _echo(msg: str = "") -> None:
    print(msg, flush=True)


def _quiet(args) -> bool:
    return bool(getattr(args, "quiet", False))


def _info(args, msg: str) -> None:
    if not _quiet(args):
        print(msg, file=sys.stderr, flush=True)


class _Progress:
    """``progress(step, i, n)`` callback for build_model drawing tqdm bars on
    stderr: one bar per step, replaced when the step changes."""

    def __init__(self, enabled: bool = True) -> None:
        self.enabled = enabled
        self.bar = None
        self.step: Optional[str] = None

    def __call__(self, step: str, i: int, n: int) -> None:
        if not self.enabled:
            return
        from tqdm import tqdm

        if step != self.step or self.bar is None:
            self.close()
            self.step = step
            # disable=None: bars only on a terminal (no carriage-return noise in logs).
            self.bar = tqdm(total=n or None, desc=f"{step:<28.28}", unit="", leave=False,
                            file=sys.stderr, dynamic_ncols=True, disable=None,
                            bar_format="{desc} {bar} {n_fmt}/{total_fmt} [{elapsed}]")
        if n and self.bar.total != n:
            self.bar.total = n
        self.bar.n = i
        self.bar.refresh()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def _builtin_datasets() -> Dict[str, Callable]:
    from . import datasets

    out = {}
    for name in ("paper_like", "synthetic"):
        fn = getattr(datasets, name, None)
        if callable(fn):
            out[name] = fn
    return out


def _load_dataset(spec: str, args=None):
    """A dataset file or folder, or a built-in name (``paper_like``, ``synthetic``).
    ``--snap`` and ``--allow-outside-paths`` of ``args`` go to load_dataset."""
    import os

    builtins = _builtin_datasets()
    # lexists: a symlink loop or a dangling link is a file the user named,
    # and load_dataset says what is wrong with it.
    if not os.path.lexists(spec) and spec in builtins:
        return builtins[spec](), spec
    if not os.path.lexists(spec):
        raise CliError(f"dataset {spec!r}: no such file, and not a built-in dataset "
                       f"({', '.join(builtins) or 'none available'})")
    from .dataset import load_dataset

    return load_dataset(spec, snap=getattr(args, "snap", None),
                        allow_outside_paths=bool(getattr(args, "allow_outside_paths", False))), None


def _dataset_record(ds, builtin: Optional[str]) -> Dict[str, object]:
    """What the run manifest says about the dataset."""
    path = getattr(ds, "path", None)
    return {"name": ds.name, "path": str(Path(path).resolve()) if path else None,
            "builtin": builtin}


def _input_summary(args, model) -> None:
    """The one-paragraph summary of what the input policy did (stdout)."""
    rec = (model.metadata or {}).get("input")
    if rec and rec.get("summary"):
        _echo(rec["summary"])


def _build_warnings(model) -> None:
    """One line on how closely the model passes through its own data
    (stdout), and the build's warnings (a datum the model misses by metres:
    build._data_fit) on stderr, also with --quiet."""
    meta = model.metadata or {}
    fit = meta.get("data_fit") or {}
    if fit:
        n = sum(r["data"] for r in fit.values())
        off = sum(r["off"] for r in fit.values())
        if not off:
            _echo(f"fit to the data: the model passes within 1 mm of all {n} data points")
        else:
            lay = max(fit, key=lambda k: fit[k]["max_m"])
            _echo(f"fit to the data: {off} of {n} data points missed by over 1 mm, the most "
                  f"{fit[lay]['max_m']:.2f} m in {lay!r} (quality.md, 'Fit to the data')")
    for w in meta.get("warnings", []):
        print(f"warning: {w}", file=sys.stderr, flush=True)


def _run_writer(args, command: str):
    from .runs import RunWriter

    return RunWriter(Path(args.output), command=command, argv=getattr(args, "argv", None))


def _model_file(run, files) -> Optional[str]:
    """The file readers should open: the richest single-file model written."""
    finals = [run.final(f) for f in files]
    for suffix in (".3dt", ".ts", ".vtu", ".vtk"):
        for f in finals:
            if f.suffix == suffix and f.parent == run.folder:
                return f.name
    return None


def _build_model_fn():
    try:
        from .build import build_model
    except ImportError as e:
        raise CliError(f"this faultmesh has no model builder (faultmesh.build: {e})") from None
    return build_model


def _build(dataset, args, progress: _Progress):
    build_model = _build_model_fn()
    # CLI option -> build_model keyword (faultmesh.build.build_model): every
    # option a user may set (_add_build_options).
    kw: Dict[str, object] = {"progress": progress}
    if getattr(args, "plain_order", False):
        kw["stitch_order"] = "plain"
    if getattr(args, "no_refine", False):
        kw["refine"] = False
    for opt, key in (("loft", "loft_method"), ("bridge", "bridge"), ("spacing", "spacing"),
                     ("clearance", "clearance"), ("max_repair_rounds", "max_repair_rounds"),
                     ("threads", "threads")):
        if getattr(args, opt, None) is not None:
            kw[key] = getattr(args, opt)
    if getattr(args, "no_repair", False):
        kw["repair"] = False
    if getattr(args, "fill_holes", False):
        kw["fill_holes"] = True
    if getattr(args, "no_evaluate", False):
        kw["evaluate"] = False
    t0 = time.perf_counter()
    try:
        model = build_model(dataset, **kw)
    except ValueError as e:  # an option value build_model refuses (GeometryError is raised on)
        if type(e) is ValueError:
            raise CliError(str(e)) from None
        raise
    finally:
        progress.close()
    return model, time.perf_counter() - t0


def _attach_builtin_truth(model) -> None:
    """Models saved by ``demo``/``build`` of a built-in dataset name it in their
    metadata; the ground truth (a function) is rebuilt from it."""
    if model.truth is not None:
        return
    spec = (model.metadata or {}).get("builtin_dataset")
    if not spec:
        return
    name = spec.get("name") if isinstance(spec, dict) else str(spec)
    kwargs = spec.get("kwargs", {}) if isinstance(spec, dict) else {}
    fn = _builtin_datasets().get(name)
    if fn is not None:
        model.truth = fn(**kwargs).truth


def _load_model(path: str):
    from .io import load_model

    p = Path(path)
    if not p.exists():
        raise CliError(f"model {path!r}: no such file or folder")
    return load_model(p)


def _sections_for(model, dataset=None) -> List[Tuple[str, object, float]]:
    """The demo's sections: the paper's two azimuths through the study area's
    centre, plus the dataset's first and last exploration line."""
    import numpy as np

    if model.boundary is not None and len(model.boundary):
        b = np.asarray(model.boundary, dtype=float)
    else:
        b = np.vstack([s.vertices[:, :2] for s in model.surfaces.values()])
    centre = (b.min(0) + b.max(0)) / 2
    out = [(f"az{az:.0f}", centre, az) for az in PAPER_AZIMUTHS]
    secs = list(getattr(dataset, "sections", {}).values()) if dataset is not None else []
    for sec in secs[:1] + secs[-1:] if len(secs) > 1 else secs:
        out.append((str(sec.name), np.asarray(sec.origin, dtype=float), float(sec.azimuth)))
    return out


def _fence_sections(model, dataset) -> list:
    """Every other exploration line of the dataset (and the last one) for the
    fence diagram."""
    secs = list(getattr(dataset, "sections", {}).values())
    if len(secs) < 3:
        return []
    pick = secs[::2] + ([secs[-1]] if (len(secs) - 1) % 2 else [])
    out = []
    for sec in pick:
        cut = model.section(sec.origin, sec.azimuth)
        cut.name = str(sec.name)
        out.append(cut)
    return out


def _write_report(model, out: Path, stem: str = "quality"):
    """quality.md/.csv/.json; the JSON (the build report) also holds the
    input policy's record (``model.metadata["input"]``) under ``"input"``."""
    import json

    rep = model.quality()
    doc = json.loads(rep.to_json())
    inp = (model.metadata or {}).get("input")
    if inp is not None:
        doc["input"] = inp
    js = out / f"{stem}.json"
    js.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    return [rep.to_markdown_file(out / f"{stem}.md"), rep.to_csv(out / f"{stem}.csv"), js], rep


def _print_tables(rep) -> None:
    t = rep.tables()
    if not t["table2"]:
        _echo("  (no stitched gaps recorded)")
        return
    _echo("  gap                      triangles   <10°    <20°   (3D angles)")
    for r in t["table2"]:
        _echo(f"  {r['gap']:<24} {r['triangles']:>9}  {100 * r['lt10']:5.1f}%  "
              f"{100 * r['lt20']:5.1f}%")


# ----------------------------------------------------------------------------
# sub-commands
# ----------------------------------------------------------------------------

def cmd_demo(args) -> int:
    out = Path(args.output)
    _check_output_folder(out, "demo")
    t_start = time.perf_counter()
    builtins = _builtin_datasets()
    if "paper_like" not in builtins:
        raise CliError("the built-in dataset paper_like is not available in this faultmesh")
    _info(args, "faultmesh demo: generating the built-in paper-like dataset ...")
    ds = builtins["paper_like"]()
    _info(args, f"  {ds.name}: {len(ds.layers)} layers, {len(ds.boreholes)} borehole rows, "
                f"{len(ds.faults)} faults, {len(ds.sections)} exploration lines")
    _info(args, "building the model ...")
    model, secs = _build(ds, args, _Progress(not _quiet(args)))
    model.metadata = dict(model.metadata or {})
    model.metadata["builtin_dataset"] = {"name": "paper_like", "kwargs": {}}
    if model.truth is None:
        model.truth = ds.truth
    _info(args, f"  built in {secs:.1f} s: " + ", ".join(
        f"{n} {s.n_triangles} triangles" for n, s in model.surfaces.items()))
    with _run_writer(args, "demo") as run:
        rep = _write_demo(run.stage, model, ds, args)
        files = sorted(p for p in run.stage.rglob("*") if p.is_file())
        run.commit(model=_model_file(run, files), dataset=_dataset_record(ds, "paper_like"),
                   extra={"input": _input_record_short(model)})
    _echo(f"faultmesh demo: model {model.name!r} built in {secs:.1f} s, everything written "
          f"in {time.perf_counter() - t_start:.1f} s to {out.resolve()}/")
    for f in files:
        _echo(f"  {run.final(f)}")
    _input_summary(args, model)
    _build_warnings(model)
    _echo("mesh quality of the stitched gaps (the paper's Table 2):")
    _print_tables(rep)
    return 0


def _write_demo(out: Path, model, ds, args):
    """Every file of the demo, written into ``out`` (the run's staging
    folder); returns the quality report."""
    from .io import save_model
    from . import plots

    save_model(model, out, formats=("3dt", "ts", "vtu"))
    _, rep = _write_report(model, out)
    sections = []
    for name, origin, az in _sections_for(model, ds):
        sec = model.section(origin, az)
        sec.name = name
        sections.append(sec)
        sec.to_csv(out / f"section_{name}.csv")
        _close(sec.plot(out / f"section_{name}.png"))
    _info(args, "drawing pictures ...")
    fence = _fence_sections(model, ds) or sections
    first = 1 if len(model.surfaces) >= 3 else 0
    for fname, fn in (("model_3d.png", lambda p: plots.plot_model_3d(model, p)),
                      ("fence_3d.png", lambda p: plots.plot_fence_3d(model, fence, p,
                                                                     first_layer=first)),
                      ("layers_3d.png", lambda p: plots.plot_layers_3d(model, p)),
                      ("gaps.png", lambda p: plots.plot_gaps(model, p)),
                      ("map.png", lambda p: plots.plot_map(model, p, sections=sections))):
        _close(fn(out / fname))
    return rep


def _input_record_short(model) -> Optional[Dict[str, object]]:
    """The input policy's counts and summary for the run manifest (the full
    list of adjustments is in the model's metadata and in quality.json)."""
    rec = (model.metadata or {}).get("input")
    if not rec:
        return None
    return {"snap_distance": rec.get("snap_distance"), "counts": rec.get("counts"),
            "summary": rec.get("summary")}


def _check_output_folder(out: Path, command: str) -> None:
    """-o must name a folder (or a path to create); checked before building."""
    import os

    if os.path.lexists(out) and not out.is_dir():
        what = "a file" if out.is_file() else "not a folder (a broken or looping symlink?)"
        raise CliError(f"-o {out}: is {what}; '{command}' writes several files into a folder")


def _close(fig) -> None:
    try:
        import matplotlib.pyplot as plt

        plt.close(fig)
    except Exception:  # pragma: no cover
        pass


def cmd_build(args) -> int:
    from .io import save_model

    out = Path(args.output)
    _check_output_folder(out, "build")
    ds, builtin = _load_dataset(args.dataset, args)
    _info(args, f"building {ds.name!r} ...")
    model, secs = _build(ds, args, _Progress(not _quiet(args)))
    if builtin:
        model.metadata = dict(model.metadata or {})
        model.metadata["builtin_dataset"] = {"name": builtin, "kwargs": {}}
    if model.truth is None and getattr(ds, "truth", None) is not None:
        model.truth = ds.truth
    formats = args.formats.split(",") if args.formats else None
    with _run_writer(args, "build") as run:
        stage = run.stage
        save_model(model, stage, formats=formats)
        _, rep = _write_report(model, stage)
        if args.plots:
            from . import plots

            _close(plots.plot_model_3d(model, stage / "model_3d.png"))
            _close(plots.plot_gaps(model, stage / "gaps.png"))
        files = sorted(p for p in stage.rglob("*") if p.is_file())
        run.commit(model=_model_file(run, files), dataset=_dataset_record(ds, builtin),
                   extra={"input": _input_record_short(model)})
    _echo(f"model {model.name!r} built in {secs:.1f} s; written to {out.resolve()}/")
    for f in files:
        _echo(f"  {run.final(f)}")
    _input_summary(args, model)
    derived = (model.metadata or {}).get("derived_faults") or {}
    if derived:
        # Faults derived from points, a surface or plane traces (a format 2
        # dataset): what the derivation found, as `faultmesh derive` says it.
        _derived_summary(derived, "the model's metadata (derived_faults; faultmesh derive writes "
                                  "them to derivation.json)")
    _build_warnings(model)
    _print_tables(rep)
    return 0


def cmd_derive(args) -> int:
    """Derive the cutoffs, tips and kind of every fault given by points, a
    surface or plane traces (faultmesh.derive) and write the derived dataset,
    the cutoff lines and the derivation report; nothing is built."""
    import json

    import numpy as np

    from .dataset import prepare_for_build
    from .derive import derive_faults, needs_derivation
    from .formats.gocad import write_polylines

    out = Path(args.output)
    _check_output_folder(out, "derive")
    ds, builtin = _load_dataset(args.dataset, args)
    todo = [f.name for f in ds.faults if needs_derivation(f)]
    if not todo:
        raise CliError(f"dataset {ds.name!r}: no fault to derive (every fault has "
                       f"{'hand-drawn cutoffs' if ds.faults else 'none: the dataset has no fault'})")
    ds, _ = prepare_for_build(ds)     # build_model's data checks, the same input
    kw: Dict[str, object] = {"min_throw": args.min_throw}
    if args.spacing is not None:
        kw["spacing"] = args.spacing
    _info(args, f"deriving {len(todo)} fault(s) of {ds.name!r} ...")
    t0 = time.perf_counter()
    derived = derive_faults(ds, **kw)
    secs = time.perf_counter() - t0
    rep = derived.derivation
    # Each cutoff line along strike, footwall and hanging wall of every cut
    # layer, as its own named PLine (GOCAD tools and faultmesh's .pl reader).
    lines = []
    for name, fd in rep.faults.items():
        for lay, sides in fd.cutoffs.items():
            for side, label in (("foot", "footwall"), ("hanging", "hanging wall")):
                P = np.asarray(sides[side], dtype=np.float64).reshape(-1, 3)
                if len(P) >= 2:
                    lines.append((f"{name} {lay} {label} cutoff", P,
                                  [f"faultmesh_fault:{name}", f"faultmesh_layer:{lay}",
                                   f"faultmesh_side:{side}"]))
    with _run_writer(args, "derive") as run:
        stage = run.stage
        derived.save(stage, version=2)
        if lines:
            write_polylines(stage / "cutoffs.pl", lines, ds.crs or "")
        doc = {"faults": rep.as_dict(), "layers": rep.layers}
        (stage / "derivation.json").write_text(json.dumps(doc, indent=1, allow_nan=False) + "\n")
        files = sorted(p for p in stage.rglob("*") if p.is_file())
        run.commit(dataset=_dataset_record(ds, builtin))
    _echo(f"{len(todo)} fault(s) of {ds.name!r} derived in {secs:.1f} s; written to {out.resolve()}/")
    for f in files:
        _echo(f"  {run.final(f)}")
    _derived_summary({name: rep.faults[name].as_dict() for name in todo}, "derivation.json")
    return 0


def _derived_summary(faults: Dict[str, Any], where: str) -> None:
    """One line per derived fault (its report as ``FaultDerivation.as_dict``):
    kind, ends, sections, the throw range per layer it cuts, how many
    warnings and ``where`` they are."""
    import numpy as np

    for name, fd in faults.items():
        thr = {lay: np.array([np.nan if v is None else v for v in t["throw"]], dtype=np.float64)
               for lay, t in fd["throw"].items()}
        cut = [f"{lay} {np.nanmin(np.abs(v)):.1f}-{np.nanmax(np.abs(v)):.1f} m"
               for lay, v in thr.items() if lay in fd["cutoffs"] and np.isfinite(v).any()]
        given = f" (given {fd['given_kind']})" if fd["given_kind"] and fd["given_kind"] != fd["kind"] else ""
        _echo(f"fault {name!r}: {fd['kind'] or 'no kind'}{given}, ends {'/'.join(fd['ends'])}, "
              f"{len(fd['sections'])} sections; throw " + (", ".join(cut) or "none: no layer is cut")
              + (f"; {len(fd['warnings'])} warning(s) in {where}" if fd["warnings"] else ""))


def cmd_section(args) -> int:
    model = _load_model(args.model)
    sec = model.section(tuple(args.origin), args.azimuth)
    if not sec.lines:
        _info(args, "warning: the section plane does not cut any surface of the model")
    if args.output:
        sec.to_csv(args.output)
        _info(args, f"wrote {args.output}")
    if args.png:
        _close(sec.plot(args.png, vertical_exaggeration=args.ve))
        _info(args, f"wrote {args.png}")
    if not args.output and not args.png:
        import csv

        w = csv.writer(sys.stdout, lineterminator="\n")
        w.writerow(["surface", "kind", "part", "s", "x", "y", "z"])
        for r in sec.to_rows():
            w.writerow([r["surface"], r["kind"], r["part"]] +
                       [repr(float(r[k])) for k in ("s", "x", "y", "z")])
    return 0


def cmd_quality(args) -> int:
    model = _load_model(args.model)
    _attach_builtin_truth(model)
    from .report import quality

    rep = quality(model, near=args.near)
    if args.json:
        rep.to_json(args.json)
        _info(args, f"wrote {args.json}")
    if args.csv:
        rep.to_csv(args.csv)
        _info(args, f"wrote {args.csv}")
    if args.markdown:
        rep.to_markdown_file(args.markdown)
        _info(args, f"wrote {args.markdown}")
    if not (args.json or args.csv or args.markdown) or args.print:
        sys.stdout.write(rep.to_markdown())
    return 0


def cmd_convert(args) -> int:
    from .io import save_model

    model = _load_model(args.input)
    files = save_model(model, args.output)
    for f in files:
        _echo(f"wrote {f}")
    return 0


def cmd_plot(args) -> int:
    from . import plots

    model = _load_model(args.model)
    if args.interactive:
        from .formats import pv

        if not pv.has_display():
            raise CliError("--interactive needs a display (DISPLAY/WAYLAND_DISPLAY is not set); "
                           "draw a picture with --png instead")
        pv.show(model, vertical_exaggeration=args.ve)
        return 0
    wrote = []
    if args.png or not args.gaps:
        target = args.png or "model_3d.png"
        _close(plots.plot_model_3d(model, target, vertical_exaggeration=args.ve,
                                   elev=args.elev, azim=args.azim))
        wrote.append(target)
    if args.gaps:
        _close(plots.plot_gaps(model, args.gaps))
        wrote.append(args.gaps)
    for w in wrote:
        _echo(f"wrote {w}")
    return 0


def _fault_overrides(specs) -> Dict[str, Dict[str, float]]:
    """``--fault NAME:key=value[,key=value]`` options -> per-fault sigmas."""
    keys = {"position": "sigma_position", "position-trace": "sigma_position_trace",
            "position_trace": "sigma_position_trace", "dip": "sigma_dip", "throw": "sigma_throw"}
    out: Dict[str, Dict[str, float]] = {}
    for spec in specs or []:
        name, sep, rest = spec.rpartition(":")
        if not sep or not name or not rest:
            raise CliError(f"--fault {spec!r}: expected NAME:key=value[,key=value] (keys: "
                           "position, position-trace, dip, throw)")
        d = out.setdefault(name, {})
        for item in rest.split(","):
            k, eq, v = item.partition("=")
            k = k.strip()
            if not eq or keys.get(k) is None:
                raise CliError(f"--fault {spec!r}: unknown or malformed item {item!r} (keys: "
                               "position, position-trace, dip, throw)")
            try:
                d[keys[k]] = float(v)
            except ValueError:
                raise CliError(f"--fault {spec!r}: {v!r} is not a number") from None
    return out


def cmd_ensemble(args) -> int:
    from .ensemble import FaultPerturbation, Grid, Perturbation, ensemble

    ds, _ = _load_dataset(args.dataset, args)
    if args.n < 1:
        raise CliError(f"-n must be at least 1, got {args.n}")
    if args.workers is not None and args.workers < 1:
        raise CliError(f"--workers must be at least 1, got {args.workers}")
    pert = Perturbation(sigma_z=args.sigma_z, sigma_z_points=args.sigma_z_points,
                        sigma_position=args.sigma_position,
                        sigma_position_trace=args.sigma_position_trace,
                        sigma_dip=args.sigma_dip, sigma_throw=args.sigma_throw,
                        faults={k: FaultPerturbation(**v)
                                for k, v in _fault_overrides(args.fault).items()})
    if pert.is_zero:
        _info(args, "note: every sigma is 0: all realizations are the unperturbed model")
    if args.sections is None or args.sections == "all":
        sections = None
    elif args.sections == "none":
        sections = ()
    else:
        sections = [s for s in args.sections.split(",") if s]
    grid = Grid.over(ds, spacing=args.spacing) if args.spacing else args.grid
    client = args.scheduler
    where = f"the Dask scheduler at {client}" if client else \
        f"a local Dask cluster of {args.workers or 'all cores as'} worker processes"
    _info(args, f"ensemble of {args.n} realizations of {ds.name!r} on {where} ...")
    bar = None
    if not _quiet(args):
        from tqdm import tqdm

        bar = tqdm(total=args.n, desc="realizations", unit="", file=sys.stderr,
                   dynamic_ncols=True, disable=None)

    def progress(done: int, n: int, failed: int) -> None:
        if bar is not None:
            bar.n = done
            if failed:
                bar.set_postfix_str(f"{failed} failed", refresh=False)
            bar.refresh()

    try:
        res = ensemble(ds, args.n, pert, client=client, seed=args.seed, grid=grid,
                       sections=sections, points="boreholes" if args.boreholes else None,
                       lower_sheet=args.lower_sheet, workers=args.workers, progress=progress)
    finally:
        if bar is not None:
            bar.close()
    if res.succeeded == 0:
        first = res.failures[0]["error"] if res.failures else "?"
        raise CliError(f"every realization failed (first: {first}); nothing written")
    files = res.save(args.output, pictures=not args.no_plots)
    t = res.timings
    _echo(f"ensemble of {ds.name!r}: {res.succeeded} of {res.n} realizations succeeded, "
          f"{res.failed} failed, in {t['wall_seconds']:.1f} s; written to "
          f"{Path(args.output).resolve()}/")
    for f in res.failures[:10]:
        _echo(f"  failed: realization {f['index']} (seed {f['seed']}): {f['error']}")
    if res.failed > 10:
        _echo(f"  ... {res.failed - 10} more in summary.json")
    for f in files:
        _echo(f"  {f}")
    return 0


# ----------------------------------------------------------------------------
# parser
# ----------------------------------------------------------------------------

def _add_common(p: argparse.ArgumentParser, top: bool = False) -> None:
    # On sub-commands the default is SUPPRESS so that "faultmesh --debug demo"
    # keeps the top-level value (argparse would overwrite it with False).
    d = False if top else argparse.SUPPRESS
    p.add_argument("--debug", action="store_true", default=d,
                   help="show the full traceback on errors")
    p.add_argument("-q", "--quiet", action="store_true", default=d,
                   help="no progress bars or notes on stderr")


def _add_dataset_options(p: argparse.ArgumentParser) -> None:
    """Options of every command that loads a dataset file (docs/dataset.md)."""
    p.add_argument("--snap", type=float, metavar="M",
                   help="snap distance in metres: data this close to the study-area boundary "
                        "are moved onto it (default: the dataset's snap_distance, else "
                        "min(0.02, 1e-5 x the area's diagonal); docs/dataset.md)")
    p.add_argument("--allow-outside-paths", action="store_true",
                   help="let the dataset JSON name CSV files outside its folder (absolute "
                        "paths, '..', symlinks leading out)")


def _positive(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (v > 0 and v < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text!r}")
    return v


def _non_negative(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (v >= 0 and v < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text!r}")
    return v


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {v}")
    return v


def _add_build_options(p: argparse.ArgumentParser) -> None:
    """Every option of faultmesh.build_model a user may set."""
    g = p.add_argument_group("model building (faultmesh.build_model)")
    g.add_argument("--plain-order", action="store_true",
                   help="clip the ears of each gap in the paper's plain (Eberly) order instead "
                        "of the best-ear-first quality order")
    g.add_argument("--no-refine", action="store_true",
                   help="keep the ear-clipped gap triangles as they are (no constrained-"
                        "Delaunay edge flips); with --plain-order this is the paper's method")
    g.add_argument("--bridge", choices=("extreme", "eberly"),
                   help="how a gap's holes are bridged: the paper's extreme-point rule "
                        "(default; Eberly's method as the fallback) or Eberly's method only")
    g.add_argument("--loft", choices=("min_area", "shortest_diagonal"),
                   help="rule for lofting the fault-model polylines: min_area (Fuchs-Kedem-"
                        "Uselton, default) or shortest_diagonal")
    g.add_argument("--clearance", type=_non_negative, metavar="M",
                   help="the removed region grows until its boundary vertices are at least M "
                        "metres from the fault patch (default: 0.4 x the layer's data spacing; "
                        "0: only the triangles touching the patch, the paper's rule)")
    g.add_argument("--spacing", type=_positive, metavar="M",
                   help="spacing of the vertices on the study-area boundary (default: about "
                        "the layer's data spacing)")
    g.add_argument("--no-repair", action="store_true",
                   help="skip the layer-crossing repair (layers may then cross)")
    g.add_argument("--fill-holes", action="store_true",
                   help="fill the layers' data holes (empty circles wider than five data "
                        "spacings) from a minimum-curvature surface instead of the TIN's "
                        "linear bridge (docs/derive.md)")
    g.add_argument("--max-repair-rounds", type=_positive_int, metavar="N",
                   help="rounds of the layer-crossing repair before it gives up (default 200)")
    g.add_argument("--no-evaluate", action="store_true",
                   help="do not compare the model with the ground truth of a built-in dataset")
    g.add_argument("--threads", type=_positive_int, metavar="N",
                   help="threads for the layers' TINs and stitching (default: the CPUs this "
                        "process may use; the model does not depend on it)")


def make_parser() -> argparse.ArgumentParser:
    from . import __version__

    fmt = argparse.RawDescriptionHelpFormatter
    parser = argparse.ArgumentParser(
        prog="faultmesh", formatter_class=fmt,
        description="Build 3D geological models of layered ground cut by faults as "
                    "triangulated surfaces, cut sections, report mesh quality, convert files.",
        epilog=MAIN_EPILOG)
    parser.add_argument("--version", action="version", version=f"faultmesh {__version__}")
    _add_common(parser, top=True)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("demo", formatter_class=fmt, help="build the built-in paper-like model "
                       "and write everything (model files, report, sections, pictures)",
                       description="Generate the built-in paper-like dataset (4 layers, 112 "
                       "boreholes, faults 2F4, F22, 2F1 and 4F2), build the model and write: "
                       "<name>.3dt/.ts/.vtu, quality.md/.csv/.json, section_*.csv/.png, "
                       "model_3d.png, fence_3d.png, layers_3d.png, gaps.png, map.png.",
                       epilog="example:\n  faultmesh demo -o demo_out")
    p.add_argument("-o", "--output", default="demo_out", metavar="DIR",
                   help="output folder (default: demo_out)")
    _add_build_options(p)
    _add_common(p)
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("build", formatter_class=fmt, help="build a model from a dataset",
                       description="Build the faulted multi-layer model of DATASET and write "
                       "it to DIR in every format (.3dt, .ts, .vtu, obj/, ply/) with the "
                       "quality report.",
                       epilog="examples:\n  faultmesh build site/dataset.json -o out\n"
                              "  faultmesh build paper_like -o out --loft shortest_diagonal "
                              "--formats 3dt,ts")
    p.add_argument("dataset", metavar="DATASET",
                   help="dataset JSON (docs/dataset.md) or a built-in name: paper_like, synthetic")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="output folder")
    _add_build_options(p)
    p.add_argument("--formats", metavar="LIST",
                   help="comma-separated formats to write (3dt,ts,vtu,vtk,obj,ply); "
                        "default 3dt,ts,vtu,obj,ply")
    p.add_argument("--plots", action="store_true", help="also draw model_3d.png and gaps.png")
    _add_dataset_options(p)
    _add_common(p)
    p.set_defaults(func=cmd_build)

    p = sub.add_parser("derive", formatter_class=fmt,
                       help="derive the fault cutoffs, tips and kind from the data and write "
                            "the derived dataset (no model)",
                       description="Derive the cutoffs, throw, tips and kind of every fault of "
                       "DATASET given by points, a surface or plane traces from the layer data "
                       "(docs/derive.md), as 'build' does before building, and write to DIR: "
                       "dataset.json (format 2, with each derived fault's traces and cutoffs: "
                       "edit them and build it, hand-drawn cutoffs win), cutoffs.pl (every "
                       "footwall and hanging-wall cutoff line as a GOCAD PLine) and "
                       "derivation.json (the derivation report).",
                       epilog="example:\n  faultmesh derive site/dataset.json -o derived\n"
                              "  faultmesh build derived/dataset.json -o out")
    p.add_argument("dataset", metavar="DATASET", help="dataset JSON (docs/dataset.md)")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="output folder")
    p.add_argument("--spacing", type=_positive, metavar="M",
                   help="distance between the derived sections along strike (default: an "
                        "eighth of each fault's length)")
    p.add_argument("--min-throw", type=_non_negative, default=3.0, metavar="M",
                   help="a layer whose throw never reaches M is not cut (default 3)")
    _add_dataset_options(p)
    _add_common(p)
    p.set_defaults(func=cmd_derive)

    p = sub.add_parser("section", formatter_class=fmt, help="cut a model by a vertical plane",
                       description="Cut every surface of MODEL by the vertical plane through "
                       "ORIGIN with the given azimuth (degrees clockwise from north). Without "
                       "-o/--png the polylines are printed as CSV (surface,kind,part,s,x,y,z).",
                       epilog="examples:\n  faultmesh section out/m.3dt --origin 4500 3200 "
                              "--azimuth 90 -o cut.csv --png cut.png\n"
                              "  faultmesh section out/m.ts --origin 0 0 --azimuth 317.09 > cut.csv")
    p.add_argument("model", metavar="MODEL", help="model file or folder")
    p.add_argument("--origin", nargs=2, type=float, required=True, metavar=("X", "Y"),
                   help="a point of the section plane")
    p.add_argument("--azimuth", type=float, required=True, metavar="DEG",
                   help="direction of the section, degrees clockwise from north")
    p.add_argument("-o", "--output", metavar="CSV", help="write the polylines to this CSV")
    p.add_argument("--png", metavar="PNG", help="draw the section (also .svg, .pdf)")
    p.add_argument("--ve", type=float, metavar="X", help="vertical exaggeration (default: automatic)")
    _add_common(p)
    p.set_defaults(func=cmd_section)

    p = sub.add_parser("quality", formatter_class=fmt, help="mesh-quality report of a model",
                       description="Per stitched gap and per surface: triangle counts and the "
                       "share of triangles with a smallest angle under 10 and 20 degrees (the "
                       "paper's Tables 1 and 2; 3D angles, XY too), and vertical errors when "
                       "the model comes from a built-in dataset. Prints markdown unless an "
                       "output file is given.",
                       epilog="example:\n  faultmesh quality out/m.3dt --json q.json --csv q.csv")
    p.add_argument("model", metavar="MODEL", help="model file or folder (.3dt keeps the gaps)")
    p.add_argument("--json", metavar="PATH", help="write the report as JSON")
    p.add_argument("--csv", metavar="PATH", help="write the report as CSV")
    p.add_argument("--markdown", metavar="PATH", help="write the report as markdown")
    p.add_argument("--print", action="store_true", help="print markdown even when writing files")
    p.add_argument("--near", type=float, default=150.0, metavar="M",
                   help="distance from a fault counted as near, in metres (default 150)")
    _add_common(p)
    p.set_defaults(func=cmd_quality)

    p = sub.add_parser("convert", formatter_class=fmt, help="convert a model between formats",
                       description="Read IN and write OUT; formats follow the suffixes "
                       "(.3dt, .ts, .ml, .vtu, .vtp, .vtk, .obj, .ply, .omf, .epc, .geoh5; "
                       "IN also .pl, .stl; a folder OUT receives .3dt, .ts, .vtu, obj/, ply/). "
                       "See docs/formats.md for what each keeps and which programs open it.",
                       epilog="examples:\n  faultmesh convert out/m.3dt m.ts\n"
                              "  faultmesh convert out/m.3dt m.ml        (SKUA/OpenGeode "
                              "structural model)\n"
                              "  faultmesh convert out/m.3dt m.omf       (Leapfrog; needs "
                              "faultmesh[omf])\n"
                              "  faultmesh convert other_tool.ts model.3dt")
    p.add_argument("input", metavar="IN")
    p.add_argument("output", metavar="OUT")
    _add_common(p)
    p.set_defaults(func=cmd_convert)

    p = sub.add_parser("plot", formatter_class=fmt, help="draw a model in 3D (and its gaps)",
                       epilog="examples:\n  faultmesh plot out/m.3dt --png model.png --gaps gaps.png\n"
                              "  faultmesh plot out/m.3dt --interactive --ve 3   (a window; "
                              "needs faultmesh[viz] and a display)")
    p.add_argument("model", metavar="MODEL")
    p.add_argument("--png", metavar="PNG", help="3D view (default model_3d.png)")
    p.add_argument("--gaps", metavar="PNG", help="stitched gaps close up")
    p.add_argument("--ve", type=float, metavar="X", help="vertical exaggeration (default: automatic)")
    p.add_argument("--elev", type=float, default=28.0, help="view elevation angle (degrees)")
    p.add_argument("--azim", type=float, default=-58.0, help="view azimuth angle (degrees)")
    p.add_argument("--interactive", action="store_true",
                   help="open the model in an interactive 3D window (PyVista) instead of "
                        "drawing pictures; needs 'pip install faultmesh[viz]' and a display")
    _add_common(p)
    p.set_defaults(func=cmd_plot)

    p = sub.add_parser("ensemble", formatter_class=fmt,
                       help="many perturbed realizations on Dask: mean, std, P10/P50/P90, "
                            "fault-block probabilities",
                       description="Build N realizations of DATASET, each from the data perturbed "
                       "by Gaussian errors (sigmas below; all 0 by default), on a local Dask "
                       "cluster or the cluster at --scheduler, and write DIR/ensemble.nc "
                       "(CF-NetCDF: mean, std, p10, p50, p90, min, max of each layer's elevation "
                       "on a grid, fault-side and fault-block probabilities, section envelopes), "
                       "std_<layer>.png, section_<name>.png and summary.json. A realization "
                       "that fails is reported with its seed; see docs/ensemble.md. Needs "
                       "pip install 'faultmesh[ensemble]'.",
                       epilog="examples:\n  faultmesh ensemble paper_like -n 200 -o ens "
                              "--sigma-z 2 --sigma-position 15 --sigma-dip 5 --sigma-throw 0.2\n"
                              "  faultmesh ensemble site/dataset.json -n 5000 -o ens "
                              "--scheduler tcp://10.0.0.5:8786 --sigma-z 1\n"
                              "  faultmesh ensemble paper_like -n 100 -o ens --sigma-position 10 "
                              "--fault F22:position=40,dip=8")
    p.add_argument("dataset", metavar="DATASET",
                   help="dataset JSON (docs/dataset.md) or a built-in name: paper_like, synthetic")
    _add_dataset_options(p)
    p.add_argument("-n", type=int, required=True, metavar="N", help="number of realizations")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="output folder")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, metavar="K",
                       help="worker processes of the local Dask cluster (default: the cores)")
    where.add_argument("--scheduler", metavar="ADDRESS",
                       help="address of a running Dask scheduler, e.g. tcp://10.0.0.5:8786")
    p.add_argument("--seed", type=int, default=0, metavar="S",
                   help="seed: realization i uses SeedSequence(S, spawn_key=(i,)) (default 0)")
    p.add_argument("--sigma-z", type=float, default=0.0, metavar="M",
                   help="elevation error of each borehole row, m (default 0)")
    p.add_argument("--sigma-z-points", type=float, default=None, metavar="M",
                   help="elevation error of each extra data point, m (default: --sigma-z)")
    p.add_argument("--sigma-position", type=float, default=0.0, metavar="M",
                   help="position of each fault across its strike, m; all its traces move "
                        "together (default 0)")
    p.add_argument("--sigma-position-trace", type=float, default=0.0, metavar="M",
                   help="extra shift of each trace across strike, m (default 0)")
    p.add_argument("--sigma-dip", type=float, default=0.0, metavar="DEG",
                   help="change of each fault's dip, degrees (default 0)")
    p.add_argument("--sigma-throw", type=float, default=0.0, metavar="R",
                   help="relative error of each fault's throw, e.g. 0.2 (default 0)")
    p.add_argument("--fault", action="append", metavar="NAME:KEY=V[,KEY=V]",
                   help="per-fault sigmas overriding the ones above; keys position, "
                        "position-trace, dip, throw (repeatable)")
    p.add_argument("--grid", type=int, default=100, metavar="NODES",
                   help="grid nodes along the longer side of the study area (default 100)")
    p.add_argument("--spacing", type=float, default=None, metavar="M",
                   help="grid spacing in m (instead of --grid)")
    p.add_argument("--sections", default=None, metavar="LIST",
                   help="sections sampled: all (default), none, or a comma-separated list of names")
    p.add_argument("--boreholes", action="store_true",
                   help="also sample every layer at the borehole collars (point_* variables)")
    p.add_argument("--lower-sheet", action="store_true",
                   help="also keep statistics of the lower sheet where a layer is repeated")
    p.add_argument("--no-plots", action="store_true", help="write no pictures")
    _add_common(p)
    p.set_defaults(func=cmd_ensemble)
    return parser


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = make_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parser.parse_args(argv)
    args.argv = argv  # for the run manifest
    debug = bool(getattr(args, "debug", False))
    if not getattr(args, "command", None):
        parser.print_help()
        return EXIT_ERROR
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print("faultmesh: interrupted", file=sys.stderr)
        return 130
    except Exception as e:  # one clear line, no traceback (unless --debug)
        if debug:
            raise
        msg = str(e) or type(e).__name__
        if isinstance(e, (FileNotFoundError, PermissionError, IsADirectoryError)) and e.filename:
            msg = f"{e.filename}: {e.strerror}"
        first = msg.strip().splitlines()[0] if msg.strip() else type(e).__name__
        kind = "" if isinstance(e, (CliError, ValueError, OSError)) else f"{type(e).__name__}: "
        print(f"faultmesh {args.command}: error: {kind}{first}", file=sys.stderr)
        return EXIT_ERROR


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
