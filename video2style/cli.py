"""The ``video2style`` command line: parse, validate, call library functions, report.

Run ``video2style COMMAND --help`` for each command's options and examples.
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from video2style.paths import check_no_links, check_outputs

EXAMPLES = """examples:
  video2style demo                                   # everything on the bundled samples
  video2style models                                 # the pose models for videos, once (or --wheel FILE offline)
  video2style pose walk.mp4 -o walk.bvh --preview walk_pose.mp4
  video2style learn old_man.mp4 --style old -o old.v2s
  video2style apply old.v2s library/ -o out/
  video2style apply --method park --domain elderly library/ -o out/ --variants 3
  video2style batch videos/ --content library/ -o results/
  video2style preview walk.bvh other.bvh -o cmp.mp4  # look at clips side by side
  video2style skeleton my_rig.bvh                    # which joint plays each role (joint maps are rarely needed)
  video2style dataset --bandai2 bandai2.tar.xz --bandai1 bandai1-seen-styles.tar.xz
  video2style train-prior --max-minutes 60           # resumable; run again to continue
  video2style evaluate --quick                       # Bandai-2 protocol: FMD, CRA, SRA, skating
"""


class CliError(Exception):
    """A user-facing error: printed as one line, exit status 1."""


class Terminated(BaseException):
    """SIGTERM, raised where the process is, so that every writer's cleanup runs (exit status 143)."""


def _writable(path: Path, flag: str, is_dir: bool = False) -> Path:
    """Check an output location before any work: a file path must not be a folder, a folder must not be
    a file, no name in it may be longer than the disk takes, and the nearest existing folder above must be
    writable. Returns ``path``."""
    path = Path(path)
    _check_name_lengths(path, flag)
    if not is_dir and path.is_dir():
        raise CliError(f"{path}: {flag} names a folder; give a file name")
    if is_dir and path.exists() and not path.is_dir():
        raise CliError(f"{path}: {flag} names a file; give a folder")
    parent = path if is_dir else path.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise CliError(f"{parent}: is a file, so {flag} {path} cannot be made inside it")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise CliError(f"{parent}: cannot write here ({flag} {path})")
    return path


def _check_name_lengths(path: Path, flag: str) -> None:
    """Refuse, before any work, an output whose name (or a folder's on the way) is longer than the disk takes."""
    existing = Path(os.path.abspath(path))
    while existing != existing.parent and not os.path.isdir(existing):
        existing = existing.parent
    try:
        most = os.pathconf(existing, "PC_NAME_MAX")
    except (OSError, ValueError):
        most = 255
    for part in Path(path).parts:
        if len(os.fsencode(part)) > most:
            raise CliError(f"{path}: {flag}: the name {part[:40]}... is {len(os.fsencode(part))} bytes long; this disk "
                           f"takes names up to {most} bytes")


STYLE_FILE_BYTES = 8 << 20  # room a style file needs: about 0.6 MB of adapters and up to 20 s of example


def _free_space(path: Path, need: int, flag: str) -> None:
    """Refuse, before any work, an output on a disk with less than ``need`` bytes free (learning takes minutes
    and a full disk would only be found when writing)."""
    import shutil

    where = Path(path).parent
    while not where.exists() and where != where.parent:
        where = where.parent
    free = shutil.disk_usage(where).free
    if free < need:
        raise CliError(f"{path}: only {free / 1e6:.1f} MB free on its disk ({flag}); {need / 1e6:.0f} MB are needed")


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("video2style")
    except PackageNotFoundError:
        return "unknown (not installed)"


def _positive(v: str) -> float:
    try:
        x = float(v)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {v}") from None
    if not x > 0:  # nan too
        raise argparse.ArgumentTypeError(f"expected a positive number, got {v}")
    return x


def _finite_positive(v: str) -> float:
    x = _positive(v)
    if x == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a finite positive number, got {v}")
    return x


def _style_option(name: str):
    """An argparse ``type`` for the style config field ``name``: the range a style file is held to
    (:func:`transfer.style_config.check_config_value`), checked while parsing, so learn never writes a file
    apply refuses."""

    def parse(v: str):
        from transfer.style_config import CONFIG_RANGES, check_config_value

        kind, low, high = CONFIG_RANGES[name]
        try:
            value = kind(v)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {'an integer' if kind is int else 'a number'} from {low} "
                                             f"to {high}, got {v}") from None
        try:
            check_config_value(name, value)
        except ValueError as e:  # the value as typed, not as parsed
            raise argparse.ArgumentTypeError(f"{str(e).rsplit(', got ', 1)[0]}, got {v}") from None
        return value

    return parse


def _checked(convert, check):
    """An argparse ``type``: ``convert(v)`` then ``check(value)``, whose ValueError ("expected ..., got ...")
    argparse prints after the option's name."""

    def parse(v: str):
        try:
            value = convert(v)
            check(value)
        except ValueError as e:  # the value as typed, not as parsed
            raise argparse.ArgumentTypeError(f"{str(e).rsplit(', got ', 1)[0]}, got {v}" if "expected" in str(e)
                                             else f"expected a number, got {v}") from None
        return value

    return parse


def _style_text(v: str) -> str:
    """``learn --style/--text``: no longer than a style file's string fields may be."""
    from transfer.style_file import check_text

    try:
        check_text(v)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    return v


def _fov(v: str) -> float:
    from lifting.camera import check_fov

    return _checked(float, check_fov)(v)


def _cutoff(v: str) -> float:
    from lifting.filtering import check_cutoff

    return _checked(float, check_cutoff)(v)


def cmd_dataset(args) -> None:
    from transfer.dataset import build_dataset

    archives = [a for a in (args.bandai2, args.bandai1) if a is not None]
    if not archives:
        raise CliError("dataset: give --bandai2 and/or --bandai1 (the .tar.xz archives)")
    for a in archives:
        if not a.is_file():
            raise CliError(f"{a}: no such file")
    check_outputs([("-o", args.out / name) for name in ("features.safetensors", "clips.json", "split.json")],
                  [("the archive", a) for a in archives])
    summary = build_dataset(archives, args.out, seed=args.seed, progress=not args.quiet)
    print(f"wrote {args.out} in {summary['seconds']:.0f} s: {summary['clips']} clips (mirrored copies included)")
    for name, s in summary["splits"].items():
        print(f"  {name:5s} {s['clips']:5d} clips {s['frames']:7d} frames {s['hours']:.2f} h")
    for f in summary["failed"]:
        print(f"  skipped {f}", file=sys.stderr)


def cmd_preview(args) -> None:
    from motioncore.retarget import load_joint_map
    from video2style.preview import preview_bvh_files

    joint_map = load_joint_map(args.joint_map) if args.joint_map else None
    _writable(args.output, "-o")
    check_outputs([("-o", args.output)], [("the input clip", c) for c in args.clips] + [("the --joint-map", args.joint_map)])
    if args.output.suffix.lower() != ".mp4":
        raise CliError(f"{args.output}: previews are .mp4 videos; give -o NAME.mp4")
    from video2style.interchange import as_bvh

    clips = [as_bvh(args, c) for c in args.clips]  # an FBX/glTF clip: its action as BVH (one Blender for all)
    out = preview_bvh_files(clips, args.output, canonical=args.canonical, joint_map=joint_map,
                            notify=lambda s: print(s, file=sys.stderr))
    print(f"wrote {out}")


def cmd_skeleton(args) -> None:
    from motioncore.retarget import RetargetError, load_joint_map
    from video2style.skeleton import (
        inspect_skeleton,
        render_roles,
        report_lines,
        write_map,
        write_template,
    )

    if args.write_map:
        _writable(args.write_map, "--write-map")
    if args.preview:
        _writable(args.preview, "--preview")
    check_outputs([("--write-map", args.write_map), ("--preview", args.preview)],
                  [("the input clip", args.file), ("the --joint-map", args.joint_map)])
    joint_map = load_joint_map(args.joint_map) if args.joint_map else None
    from video2style.interchange import as_bvh

    source, args.file = args.file, as_bvh(args, args.file)  # an FBX/glTF clip: its armature as BVH
    try:
        rep = inspect_skeleton(args.file, joint_map)
        rep.path = source
    except RetargetError:
        if args.write_map and args.joint_map is None:  # a template to fill in
            names = write_template(args.file, args.write_map)
            print(f"wrote {args.write_map}: a template; put your joint's name for each role and pass it with "
                  f"--joint-map (null only for Spine, Neck, Shoulder_L/R, Toes_L/R). Your joints: {', '.join(names)}",
                  file=sys.stderr)
        raise
    print("\n".join(report_lines(rep)))
    if args.write_map:
        print(f"wrote {write_map(rep, args.write_map)} (edit it, then pass --joint-map {args.write_map})")
    if args.preview:
        print(f"wrote {render_roles(rep, args.preview)}")


def cmd_models(args) -> None:
    from lifting.blazepose.assets import (
        WHEEL_ABOUT,
        ModelUnavailableError,
        ensure_models,
        find_models,
        model_dir,
    )

    found = find_models()
    if found is not None and args.wheel is None:
        print("BlazePose models: ready")
        for name, path in found.items():
            print(f"  {name}: {path} ({path.stat().st_size / 1e6:.1f} MB)")
        return
    if args.check:
        raise CliError(f"BlazePose models: missing from {model_dir()}; run `video2style models` (fetches {WHEEL_ABOUT}) "
                       "or `video2style models --wheel FILE.whl` offline")
    if args.wheel is not None and not args.wheel.is_file():
        raise CliError(f"{args.wheel}: no such file (expected the mediapipe wheel)")
    if args.wheel is not None:
        from lifting.blazepose.assets import MODELS

        check_outputs([("a model file", model_dir() / f"{name}.onnx") for name in MODELS], [("the --wheel file", args.wheel)])
    try:
        paths = ensure_models(wheel=args.wheel)
    except ModelUnavailableError as e:
        raise CliError(" ".join(str(e).split())) from None
    for name, path in paths.items():
        print(f"  {name}: {path}")


def _explicit(args, config_class) -> dict:
    """The training settings the user gave on the command line (the rest: the resumed run's own, or defaults)."""
    from dataclasses import fields

    explicit = {f.name: getattr(args, f.name) for f in fields(config_class) if getattr(args, f.name, None) is not None}
    if "exclude_styles" in explicit:
        explicit["exclude_styles"] = tuple(sorted(set(explicit["exclude_styles"])))
    return explicit


def cmd_train_prior(args) -> None:
    from transfer.prior import PriorTrainConfig, convergence, read_val_log, train_prior

    _run_folder_checks(args, ["checkpoint.safetensors", "denoiser.safetensors", "denoiser.json", "val.csv"])
    explicit = _explicit(args, PriorTrainConfig)
    config = PriorTrainConfig(**explicit)
    trainer = train_prior(args.data, args.out, config, args.max_minutes, args.max_steps, explicit, progress=not args.quiet,
                          device=args.device)
    print(f"step {trainer.step}, {trainer.elapsed / 60:.1f} min in all; weights: {args.out / 'denoiser.safetensors'}")
    log = read_val_log(args.out / "val.csv")
    fall = convergence(log)
    if fall is not None:
        verdict = "converged (< 2 %)" if fall < 0.02 else "not converged yet: run again to continue"
        print(f"validation loss {log[-1][1]:.4f} at step {log[-1][0]}; fell {100 * fall:.1f} % over the last fifth "
              f"of the steps: {verdict}")


def cmd_train_encoder(args) -> None:
    from transfer.motion_encoder import EncoderTrainConfig, train_motion_encoder

    _run_folder_checks(args, ["checkpoint.safetensors", "motion_encoder.safetensors", "motion_encoder.json", "val.csv"],
                       [("the --prior file", args.prior), ("the folder of --prior", args.prior.parent)])
    explicit = _explicit(args, EncoderTrainConfig)
    trainer = train_motion_encoder(args.data, args.prior, args.out, EncoderTrainConfig(**explicit), args.max_minutes,
                                   args.max_steps, explicit, progress=not args.quiet, device=args.device)
    print(f"step {trainer.step}, {trainer.elapsed / 60:.1f} min in all; weights: {args.out / 'motion_encoder.safetensors'}")


def cmd_learn(args) -> None:
    from dataclasses import replace

    from motioncore.retarget import load_joint_map
    from transfer.style_config import ApplyConfig, LearnConfig
    from video2style.interchange import as_bvh
    from video2style.pipeline import learn_file

    config, apply_config = LearnConfig(), ApplyConfig()
    if args.max_seconds is not None:
        config = replace(config, max_seconds=args.max_seconds)
    if args.iterations is not None:
        config = replace(config, iterations=args.iterations)
    if args.seed is not None:
        config = replace(config, seed=args.seed)
    if args.calibrate:
        config = replace(config, calibrate=True)
    if args.limb_guard is not None:
        apply_config = replace(apply_config, limb_guard=args.limb_guard)
    if args.posture is not None:
        apply_config = replace(apply_config, posture=args.posture)
    if args.arm_gate is not None:
        apply_config = replace(apply_config, arm_gate=args.arm_gate)
    if args.arm_travel is not None:
        apply_config = replace(apply_config, arm_travel=args.arm_travel)
    if args.content_keep is not None:
        apply_config = replace(apply_config, content_keep=args.content_keep)
    out = _writable(args.output or Path(args.input.stem + ".v2s"), "-o")
    check_outputs([("-o", out)], [("the input", args.input), ("the --joint-map", args.joint_map)])
    _free_space(out, STYLE_FILE_BYTES, "-o")
    joint_map = load_joint_map(args.joint_map) if args.joint_map else None
    args.input = as_bvh(args, args.input)  # an FBX/glTF clip: its action as BVH
    summary = learn_file(args.input, out, args.style, args.text, config, joint_map, allow_partial=args.allow_partial,
                         span=(args.start, args.end), show_bar=True, device=args.device, rotate=args.rotate,
                         apply_config=apply_config)
    if summary["partial"]:
        print(f"warning: {summary['partial']} (kept because of --allow-partial)", file=sys.stderr)
    print(learned_line(summary, out))


def learned_line(summary: dict, out: Path) -> str:
    """learn's closing line: the content said as fact only when it was given or recognised with confidence."""
    sure = summary.get("content_confident", True)
    line = (f"learned style {summary['style']!r}" + (f" ({summary['content']})" if sure else "")
            + f" in {summary['seconds']:.0f} s, {summary['iterations']} iterations -> {out} "
              f"({summary['bytes'] / 1024:.0f} KiB)")
    if not sure:
        line += (f"; what the person does was not recognised with confidence (closest guess: {summary['content']!r}): "
                 "if that is wrong, learn again with --text 'a person ...'")
    return line


def _bvh_inputs(paths: list[Path], out_dir: Path, others: list[tuple[str, Path | None]] = (),
                fmt: str | None = None) -> list[tuple[Path, Path]]:
    """``(clip, folder its results go to)``: a folder's clips keep their subfolders under ``out_dir``; results in it
    are not taken as clips (:func:`video2style.pipeline.content_clips`). Refused before any work: two clips that
    would write the same output, and outputs that would overwrite an input (a clip, its folder, or ``others``:
    ``(what, path)`` of the other files read), or a clip of the user's already in a folder no run of ours wrote
    (:func:`users_clips_in_the_way`). ``fmt``: ``--format`` (results in that format; None: each clip's own)."""
    from video2style.pipeline import content_clips

    files, protected = [], []
    for p in paths:
        if p.is_dir():
            files += [(q, out_dir / q.relative_to(p).parent)
                      for q in content_clips(p, out_dir, lambda s: print(s, file=sys.stderr), protected=protected)]
        else:
            files.append((p, out_dir))
    from video2style.interchange import find_clip_files

    files += [(q, out_dir / q.relative_to(p).parent) for p in paths if p.is_dir()
              for q in find_clip_files(p, out_dir, protected=protected)]
    if not files:
        raise CliError("apply: no BVH files (nor FBX/glTF clips) found in the inputs")
    seen: dict[Path, Path] = {}
    for clip, where in files:
        target = where / f"{clip.stem}.bvh"  # every result is first a BVH of this name, whatever its format
        if target in seen:
            other = seen[target]
            if other.parent == clip.parent:
                raise CliError(f"apply: {other} and {clip} share the name {clip.stem!r} in one folder; their results "
                               f"(in {where}) are made under that one name: rename one or apply them separately")
            raise CliError(f"apply: {other} and {clip} would both write {target}; give their folder "
                           "instead (subfolders are kept) or apply them separately")
        seen[target] = clip
    check_no_links(out_dir, dict.fromkeys(where for _, where in files))
    from video2style.interchange import result_suffixes

    outputs = [("-o", where / f"{clip.stem}{end}") for clip, where in files
               for end in (*result_suffixes(clip, fmt), "_preview.mp4", "_player.js")]
    outputs += [("-o", out_dir / name) for name in ("report.json", "index.html")]
    folders = [("-o", where) for where in dict.fromkeys(where for _, where in files)]
    check_outputs(outputs + folders,  # nor a clip's own folder: its results (and variants) would land beside it
                  [("the input clip", clip) for clip, _ in files] + [("the folder of the input clip", clip.parent)
                                                                     for clip, _ in files] + list(others)
                  + [("a clip in the input folder", clip) for clip in protected]
                  + [("a clip of yours in a folder no run of video2style wrote", p)
                     for p in users_clips_in_the_way(path for _, path in outputs)])
    return files


def users_clips_in_the_way(outputs) -> list[Path]:
    """The clip files (BVH, FBX, glTF) among ``outputs`` that exist already in a folder no run of ours has held
    (no ``.video2style.lock`` in it or above): the user's own, which a result must never replace."""
    from video2style.interchange import CLIP_SUFFIXES
    from video2style.paths import LOCK_NAME

    found, ours = [], {}
    for path in outputs:
        path = Path(path)
        if path.suffix.lower() not in {".bvh", *CLIP_SUFFIXES} or not os.path.lexists(path):
            continue
        folder = path.parent
        if folder not in ours:
            ours[folder] = any((q / LOCK_NAME).exists() for q in [folder, *Path(os.path.abspath(folder)).parents])
        if not ours[folder]:
            found.append(path)
    return found


def cmd_apply(args) -> None:
    from motioncore.retarget import load_joint_map
    from video2style.batch import folder_lock

    joint_map = load_joint_map(args.joint_map) if args.joint_map else None
    _writable(args.output, "-o", is_dir=True)
    if args.method in ("park", "stgcn"):  # stgcn: the older name
        run_item, files = _park_runner(args, joint_map)
        heading, facts = f"park: {args.domain}", f"Park et al.'s stylizer, domain {args.domain}"
    else:
        run_item, files = _diffusion_runner(args, joint_map)
        from video2style.batch import _style_facts

        heading, facts = args.style.name, _style_facts(args.apply_style, args.strength)
    from video2style.interchange import in_formats

    run_item = in_formats(args, run_item)  # FBX/glTF clips in, results in --format (default: the clip's own)
    with folder_lock(args.output, "apply", [where for _, where in files]):  # two runs into one folder would mix outputs
        _sweep_outputs(where for _, where in files)
        failed, rows = _apply_all(run_item, files)
        if len(rows) > failed:  # a run that made nothing leaves nothing (its errors are printed)
            _apply_pages(rows, args.output, heading, facts, page=not args.no_preview)
    if failed:
        raise CliError(f"{failed} of {len(files)} clips failed (listed above)")


def _sweep_outputs(folders) -> None:
    """Remove the temporary files an interrupted run left in the folders this apply writes (only files of our own
    making, :func:`video2style.batch.sweep_temp_files`); called holding the output folder's lock."""
    from video2style.batch import sweep_temp_files

    stale = sum(sweep_temp_files(Path(f), recursive=False) for f in dict.fromkeys(folders) if Path(f).is_dir())
    if stale:
        print(f"removed {stale} temporary file(s) left by an interrupted run", file=sys.stderr)


def _apply_pages(rows: list[dict], out_dir: Path, heading: str, facts: str, page: bool = True) -> None:
    """apply's ``report.json`` (a row per clip: :func:`video2style.summary.clip_details`) and, with ``page`` (not
    under --no-preview: no players to show), ``index.html``, the page batch and demo write
    (:func:`video2style.batch.write_index`)."""
    from video2style.batch import BatchReport, write_index
    from video2style.summary import write_report

    report = BatchReport([{"video": heading, "style": facts, **r} for r in rows])
    print(f"report: {write_report(report.rows, out_dir)}")
    if page:
        print(f"index: {write_index(report, out_dir, 'video2style apply results')} (open it in a browser: every "
              "result beside its content clip and style example)")


def _apply_all(run_item, files: list[tuple[Path, Path]]) -> tuple[int, list[dict]]:
    """Run each ``(clip, folder)`` item, printing a short line per clip (:func:`video2style.summary.clip_line`);
    returns how many failed and a report row per clip (:func:`video2style.summary.clip_details`)."""
    from video2style.summary import clip_details

    failed, rows = 0, []
    for i, (path, where) in enumerate(files, 1):
        try:
            info = run_item(path, where)
        except (ValueError, FileNotFoundError, OSError) as e:
            from motioncore.text import printable

            failed += 1
            print(f"[{i}/{len(files)}] {printable(path)}: error: {printable(e)}", file=sys.stderr)
            rows.append({"clip": path.name, "content": str(path), "status": "failed", "error": printable(e)})
            continue
        outs = info["output"] if isinstance(info["output"], list) else [info["output"]]
        details = clip_details(info)
        print(f"[{i}/{len(files)}] {path} -> {', '.join(outs)}: {details['summary']}")
        rows.append({"clip": path.name, "content": str(path), "status": "done", **details, "output": outs[0],
                     "outputs": outs})
        if info.get("preview_note"):
            print(f"    note: {info['preview_note']}", file=sys.stderr)
        if info.get("stream_note"):
            print(f"    note: {info['stream_note']}", file=sys.stderr)
    return failed, rows


def _diffusion_runner(args, joint_map):
    from transfer.bundle import base_model_warning, load_models
    from transfer.style_file import Style, style_model
    from video2style.options import apply_options
    from video2style.pipeline import apply_file

    if args.style is None or args.style.suffix.lower() == ".bvh" or args.style.is_dir():
        raise CliError("apply: the first argument must be a style file from `video2style learn` (or use --method park --domain D)")
    for flag in ("domain", "reference", "mix"):
        if getattr(args, flag) is not None:
            raise CliError(f"apply: --{flag} belongs to --method park")
    options = apply_options(args)  # one line for a bad --strength or --tempo, before the style loads
    style = args.apply_style = Style.load(args.style)
    files = _bvh_inputs(args.inputs, args.output, [("the style file", args.style), ("the --joint-map", args.joint_map)],
                        getattr(args, "format", None))
    model = style_model(load_models(args.device).prior, style)  # apply_file runs on the model's device
    warning = base_model_warning(style, args.style)
    if warning:
        print(warning, file=sys.stderr)
    return (lambda path, where: apply_file(style, model, path, where, options.strength, options.seed, options.neutralize,
                                           joint_map, options.preview, options.tempo, options.feet)), files


def _park_runner(args, joint_map):
    from video2style.park_apply import ParkRequest, apply_park_file, park_model

    if args.domain is None:
        raise CliError("apply --method park: give --domain (one of the style domains, e.g. elderly)")
    inputs = ([args.style] if args.style is not None else []) + args.inputs  # no style file with this method
    files = _bvh_inputs(inputs, args.output, [("the --joint-map", args.joint_map), ("the --reference clip", args.reference),
                                              ("the --park-weights file", args.park_weights)],
                        getattr(args, "format", None))
    model = park_model(args.park_weights, args.device)
    request = ParkRequest(args.domain, args.seed, args.variants, args.reference, args.mix, args.mix_steps)
    request.validate(list(model.config.domains))
    return (lambda path, where: apply_park_file(model, path, where, request, joint_map, not args.no_preview)), files


def cmd_pose(args) -> None:
    from video2style.pose import pose_file

    if args.trajectory not in ("auto", "contacts", "camera"):
        raise CliError(f"pose: --trajectory expected auto, contacts or camera, got {args.trajectory!r}")
    out = _writable(args.output or args.video.with_suffix(".bvh"), "-o")
    if args.preview is not None:
        _writable(args.preview, "--preview")
    check_outputs([("-o", out), ("--preview", args.preview)], [("the input video", args.video)])
    info = pose_file(args.video, out, args.preview, args.cutoff or None, progress=not args.quiet,
                     fov_deg=args.fov, trajectory=args.trajectory, span=(args.start, args.end),
                     rotate=args.rotate)
    print(f"wrote {info['bvh']}: {info['bvh_frames']} frames at {info['bvh_fps']:g} fps ({info['bvh_seconds']:.2f} s), "
          f"person tracked in {info['tracked_frames']}/{info['frames']} video frames, trajectory from "
          f"{info['trajectory']}; tracking ran at {info['fps']:.1f} video frames a second"
          + (f"; preview {info['preview']}" if info["preview"] else ""))


def cmd_train_park(args) -> None:
    import dataclasses

    import torch

    from park.train import ParkTrainConfig, default_weights, train_park

    explicit = {k: getattr(args, k) for k in ("batch_size", "window", "seed", "ds_decay_steps") if getattr(args, k) is not None}
    config = ParkTrainConfig(**explicit)
    if args.lambda_ds is not None:
        config.weights = dataclasses.replace(config.weights, ds=args.lambda_ds)
        explicit["weights"] = dataclasses.asdict(config.weights)
    if args.init is not None and not args.init.is_file():
        raise SystemExit(f"error: {args.init}: no such weights file (--init)")
    weights = args.weights or args.out / default_weights().name  # the shipped file only when named
    _run_folder_checks(args, ["checkpoint.safetensors", "log.csv"], [("the --init weights", args.init)],
                       [("--weights", weights), ("--weights", weights.with_suffix(".json"))])
    if args.threads:
        torch.set_num_threads(args.threads)
    card = train_park(args.data, args.out, config, args.max_minutes, args.max_steps,
                      weights, explicit, progress=not args.quiet, init_path=args.init, device=args.device)
    print(f"step {card.get('steps', '?')}; weights: {weights}")


def cmd_train_classifier(args) -> None:
    import torch

    from evaluation.classifiers import (
        ClassifierTrainConfig,
        default_weights,
        train_classifier,
    )

    if args.threads:
        torch.set_num_threads(args.threads)
    explicit = {"seed": args.seed} if args.seed is not None else {}
    out = args.out or args.run_root / f"classifier_{args.target}"
    weights = args.weights or out / default_weights(args.target).name  # the shipped file only when named
    check_outputs([("--out", out), ("--out", out / "checkpoint.safetensors"), ("--out", out / "log.csv"),
                   ("--weights", weights), ("--weights", weights.with_suffix(".json"))], _data_inputs(args.data))
    card = train_classifier(args.data, out, args.target, args.max_minutes, args.max_steps,
                            ClassifierTrainConfig(target=args.target, **explicit), weights, explicit, progress=not args.quiet,
                            device=args.device)
    print(f"{args.target} classifier: step {card['steps']}, test accuracy {100 * card['test_accuracy']:.1f}% "
          f"on {card['test_clips']} clips; weights: {weights}")


def cmd_evaluate(args) -> None:
    from video2style.evaluate import evaluate, evaluate_dev_styles

    if args.dev_styles is not None:
        archives = [args.dev_styles / name for name in ("bandai1-unseen-dev-styles.tar.xz", "bandai1-seen-styles.tar.xz")]
        missing = [str(a) for a in archives if not a.is_file()]
        if missing:
            raise CliError(f"evaluate --dev-styles: no {missing[0]}")
        check_outputs([("-o", args.out), ("-o", args.out / "dev_styles.md"), ("-o", args.out / "dev_styles.json")],
                      [("--dev-styles", a) for a in archives])
        calibrate = args.methods is not None and "ours-calibrated" in args.methods
        for line in evaluate_dev_styles(*archives, args.out, strength=0.5 if args.strengths is None else args.strengths[0],
                                        seed=args.seed, calibrate=calibrate, style_cache=args.style_cache):
            print(line)
        return
    inputs = _data_inputs(args.data) + [("the --park-weights file", args.park_weights),
                                        ("the --unseen-models folder", args.unseen_models)]
    check_outputs([("-o", args.out)] + [("-o", args.out / name) for name in ("table.md", "rows.json", "tradeoff.png")], inputs)
    check_outputs([("--style-cache", args.style_cache)], inputs)
    for line in evaluate(args.data, args.out, quick=args.quick, methods=args.methods, seed=args.seed,
                         examples_pool=args.examples_pool, park_weights=args.park_weights, split=args.split,
                         strengths=args.strengths, iterations=args.iterations, style_cache=args.style_cache,
                         unseen=args.unseen, unseen_models=args.unseen_models, words=args.style_words,
                         groups=args.groups):
        print(line)


def cmd_batch(args) -> None:
    from video2style.batch import run_batch
    from video2style.options import apply_options

    options = apply_options(args)  # the same options, checked the same way, as apply's
    _writable(args.output, "-o", is_dir=True)
    _free_space(args.output / "styles" / "style.v2s", STYLE_FILE_BYTES, "-o")  # room for at least one style
    if args.ray is not None:
        from video2style.batch_ray import run_batch_ray

        report = run_batch_ray(args.inputs, args.content, args.output, options=options,
                               address=None if args.ray == "local" else args.ray, workers=args.workers, device=args.device,
                               rotate=args.rotate)
    else:
        if args.workers is not None:
            raise CliError("batch: --workers goes with --ray")
        report = run_batch(args.inputs, args.content, args.output, options=options, device=args.device,
                           rotate=args.rotate)
    print(report.table())
    print(f"report: {args.output / 'report.json'}")
    print(f"index: {args.output / 'index.html'}")
    if report.failures:
        raise CliError(f"{len(report.failures)} item(s) failed (see the table)")


def cmd_demo(args) -> None:
    from video2style.demo import run_demo

    report = run_demo(_writable(args.out, "-o", is_dir=True))
    if report.failures:
        raise CliError(f"{len(report.failures)} demo item(s) failed (see the table)")


def _run_folder_checks(args, names: list[str], inputs: list[tuple[str, Path | None]] = (),
                       outputs: list[tuple[str, Path]] = ()) -> None:
    """A training command's refusals before any work: ``--out`` (and the files ``names`` it writes there, and
    ``outputs``) must not be the ``--data`` folder or another input (:func:`video2style.paths.check_outputs`)."""
    check_outputs([("--out", args.out)] + [("--out", args.out / name) for name in names] + list(outputs),
                  _data_inputs(args.data) + list(inputs))


def _data_inputs(data: Path) -> list[tuple[str, Path]]:
    """The dataset cache a command reads: its folder and files (:func:`transfer.dataset.build_dataset` writes them)."""
    return [("the --data folder", data)] + [("a --data file", data / name)
                                            for name in ("features.safetensors", "clips.json", "split.json")]


def _non_negative(v: str) -> float:
    try:
        x = float(v)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {v}") from None
    if not 0 <= x < float("inf"):  # nan too
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {v}")
    return x


def _non_negative_int(v: str) -> int:
    try:
        x = int(v)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0, got {v}") from None
    if x < 0:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0, got {v}")
    return x


def _positive_int(v: str) -> int:
    try:
        x = int(v)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {v}") from None
    if x <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {v}")
    return x


def _add_rotate(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--rotate", type=int, choices=(0, 90, 180, 270), metavar="{0,90,180,270}",  # upright.ROTATIONS
                        help="turn the video's frames this many degrees clockwise before tracking (after the rotation "
                             "tag a phone writes, which is applied); a person upside down or on their side is refused "
                             "naming the turn to give; 0 keeps the frames as they are")


def _add_device(parser: argparse.ArgumentParser) -> None:
    from transfer.device import DEVICE_HELP, DEVICES

    parser.add_argument("--device", choices=DEVICES, default="cpu", help=DEVICE_HELP)


def _add_exclude_styles(parser: argparse.ArgumentParser) -> None:
    from transfer.captions import NEUTRAL_STYLE, STYLES

    parser.add_argument("--exclude-styles", dest="exclude_styles", nargs="+", default=None, metavar="STYLE",
                        choices=[s for s in STYLES if s != NEUTRAL_STYLE],
                        help="leave every clip of these styles (and their captions) out of training, for the unseen-style "
                             "protocol (evaluate --unseen); a resumed run keeps its own")


def _device_error(args) -> str | None:
    """The one-line error for a ``--device`` this machine cannot run, checked before any work, else None. A batch
    joining a Ray cluster is checked against the cluster's GPUs instead (:func:`video2style.batch_ray.task_device`)."""
    if getattr(args, "device", "cpu") == "cpu" or getattr(args, "ray", None) not in (None, "local"):
        return None
    from transfer.device import resolve_device

    try:
        resolve_device(args.device)
    except ValueError as e:
        return str(e)
    return None


def build_parser() -> argparse.ArgumentParser:
    from transfer.style_config import MIN_ITERATIONS, ApplyConfig, LearnConfig
    from video2style.methods import ALIASES, METHODS
    from video2style.paths import cache_dir, default_dataset_dir

    p = argparse.ArgumentParser(prog="video2style", description=__doc__, epilog=EXAMPLES,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--version", action="version", version=f"video2style {_version()}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    m = sub.add_parser("demo", help="run the pipeline on the bundled samples/ (project-made clips)")
    m.add_argument("-o", "--out", type=Path, default=Path("demo_out"), help="output folder (default: ./%(default)s)")
    m.set_defaults(func=cmd_demo)

    d = sub.add_parser("dataset", help="build the training cache from the Bandai-Namco archives")
    d.add_argument("--bandai2", type=Path, help="Bandai-Namco-Research-Motiondataset-2 .tar.xz")
    d.add_argument("--bandai1", type=Path, help="Bandai-Namco-Research-Motiondataset-1 (seen styles) .tar.xz")
    d.add_argument("-o", "--out", type=Path, default=default_dataset_dir(), help="cache folder (default: %(default)s)")
    d.add_argument("--seed", type=_style_option("seed"), default=0, help="split seed (default: %(default)s)")
    d.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    d.set_defaults(func=cmd_dataset)

    from video2style.interchange import add_arguments as add_clip_format_arguments

    v = sub.add_parser("preview", help="render BVH clips side by side to an mp4",
                       epilog="example: video2style preview a.bvh b.bvh --canonical -o ab.mp4")
    v.add_argument("clips", nargs="+", type=Path, help="BVH (or FBX, GLB, glTF) clips, drawn side by side")
    v.add_argument("-o", "--output", type=Path, required=True, help="output .mp4")
    v.add_argument("--canonical", action="store_true", help="retarget to the canonical skeleton first")
    v.add_argument("--joint-map", type=Path, help="rarely needed: skeletons are mapped automatically (see `video2style skeleton FILE`); a JSON map of canonical role -> your joint name overrides the roles it names")
    add_clip_format_arguments(v)
    v.set_defaults(func=cmd_preview)

    mo = sub.add_parser("models", help="get the pose models a video needs (one time; shows what is fetched)",
                        epilog="examples:\n  video2style models                       # fetch from PyPI once (about 36 MB)\n"
                               "  video2style models --wheel mediapipe-0.10.14-cp311-...whl   # offline\n"
                               "  video2style models --check               # exit 1 if they are missing\n\n"
                               "The BlazePose models are read from MediaPipe's wheel (Apache License 2.0), checked against\n"
                               "pinned sha256 digests and converted to ONNX in the cache folder ($VIDEO2STYLE_CACHE);\n"
                               "mediapipe itself is never installed. The other models ship inside video2style.",
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    mo.add_argument("--wheel", type=Path, help="a mediapipe 0.10.14 wheel you already have (no network needed)")
    mo.add_argument("--check", action="store_true", help="only say whether they are there (exit 1 if not)")
    mo.set_defaults(func=cmd_models)

    sk = sub.add_parser("skeleton", help="show which joint of a BVH file plays each role (and write a joint map)",
                        epilog="examples:\n  video2style skeleton mixamo_walk.bvh\n"
                               "  video2style skeleton rig.bvh --write-map map.json --preview roles.png\n"
                               "  video2style skeleton rig.bvh --joint-map map.json   # check your edits\n\n"
                               "Roles are found from the hierarchy and the rest pose (T or A pose, any up axis, any\n"
                               "units); names only tell left from right when the feet cannot. A joint map is rarely\n"
                               "needed: write one here, fix the roles that are wrong, and pass it to learn/apply.\n"
                               "A map may be partial: it overrides only the roles it names (null: no such bone).",
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    sk.add_argument("file", type=Path, help="a BVH file (or an FBX, GLB, glTF clip)")
    sk.add_argument("--write-map", type=Path, metavar="MAP.json", help="write the mapping as an editable joint map")
    sk.add_argument("--preview", type=Path, metavar="IMAGE.png", help="draw the pose read with the roles coloured")
    sk.add_argument("--joint-map", type=Path, metavar="MAP.json", help="your map: overrides the roles it names")
    add_clip_format_arguments(sk)
    sk.set_defaults(func=cmd_skeleton)

    lr = sub.add_parser("learn", help="learn a style from a video or a BVH clip",
                        epilog="examples:\n  video2style learn old_man.mp4 --style old -o old.v2s\n"
                               "  video2style learn strut.bvh --style strutting --text 'a person walks'\n"
                               "  video2style learn diver.mp4 --style 'scuba diver' --start 0.6   # skip the first 0.6 s\n\n"
                               "The budget is iterations, so the same input gives the same style file on any machine;\n"
                               "a style learned in too few iterations is refused unless --allow-partial.",
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    lr.add_argument("input", type=Path, help="video (.mp4, .mov, ...), .bvh, or an FBX/GLB/glTF clip")
    lr.add_argument("--style", type=_style_text, help="a name for the style, e.g. 'old', kept in the style file; learning does not use it "
                    "unless the style's config turns on lambda_s (default: from the file name)")
    lr.add_argument("--text", type=_style_text, help="what the person does, e.g. 'a person walks' (default: recognised)")
    lr.add_argument("-o", "--output", type=Path, help="style file (default: <input name>.v2s)")
    lr.add_argument("--calibrate", action="store_true",
                    help="scale the style so results differ from their content as much as the example differs from "
                         "its neutral version (measured on neutral clips of other actions; more style, the action "
                         "read less often: docs/RESULTS.md \"A style's amount follows its example\")")
    lr.add_argument("--iterations", type=_style_option("iterations"),
                    help=f"fine-tuning iterations: the budget, the same on any machine (default: {LearnConfig.iterations})")
    lr.add_argument("--max-seconds", type=_style_option("max_seconds"),
                    help="optional wall-clock cap on learning; if it cuts learning short, learn fails unless --allow-partial")
    lr.add_argument("--allow-partial", action="store_true",
                    help=f"keep a style cut short by --max-seconds or learned in fewer than {MIN_ITERATIONS} iterations")
    lr.add_argument("--seed", type=_style_option("seed"), help=f"random seed (default: {LearnConfig.seed})")
    lr.add_argument("--limb-guard", type=_style_option("limb_guard"), metavar="METRES",
                    help="at apply, a hand or foot whose mean place strays further than this from anywhere between the "
                         f"content's and the example's is drawn back (default: {ApplyConfig.limb_guard}; 0: off)")
    lr.add_argument("--posture", type=_style_option("posture"), metavar="0-1",
                    help="at apply, how far each joint's mean place follows the example's (against its neutral pair) "
                         f"rather than the style model's change (default: {ApplyConfig.posture}; 0: off)")
    lr.add_argument("--arm-gate", type=_style_option("arm_gate"), metavar="METRES",
                    help="at apply, an arm whose hand is further than this from every place the example's hand takes "
                         "(hands raised where the example walks) keeps the content's motion, easing in over 0.2 m "
                         f"(default: {ApplyConfig.arm_gate}; 0: off)")
    lr.add_argument("--arm-travel", type=_style_option("arm_travel"), metavar="SHARE",
                    help="at apply, a clip that travels over the ground less than this share of the example's speed "
                         "(a wave under a walk's style) keeps its arms' motion, held where the example holds its arms "
                         f"(default: {ApplyConfig.arm_travel}; 0: off)")
    lr.add_argument("--content-keep", type=_style_option("content_keep"), metavar="0-1",
                    help="at apply, the style's change is scaled down (to 3/4, 1/2, 1/4) until the motion encoder reads "
                         "the content's action first again, or with at least this share of its certainty on the "
                         "content; clips it "
                         f"does not know are left as they are (default: {ApplyConfig.content_keep}; 0: off)")
    lr.add_argument("--start", type=float, help="use the input from this time on, in seconds")
    lr.add_argument("--end", type=float, help="use the input up to this time, in seconds")
    lr.add_argument("--joint-map", type=Path, help="rarely needed: skeletons are mapped automatically (see `video2style skeleton FILE`); a JSON map of canonical role -> your joint name overrides the roles it names")
    _add_rotate(lr)
    _add_device(lr)
    add_clip_format_arguments(lr)
    lr.set_defaults(func=cmd_learn)

    ap = sub.add_parser("apply", help="apply a learned style (or Park et al.'s ST-GCN stylizer) to BVH clips",
                        epilog="examples:\n  video2style apply old.v2s library/ -o out/ --strength 0.6\n"
                               "  video2style apply --method park --domain elderly walk.bvh -o out/ --variants 4\n"
                               "  video2style apply --method park --domain elderly walk.bvh -o out/ --reference old.bvh\n"
                               "  video2style apply --method park --domain elderly walk.bvh -o out/ --mix exhausted",
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("style", type=Path, nargs="?", help="style file from `video2style learn` (not with --method park)")
    ap.add_argument("inputs", nargs="*", type=Path, help="BVH, FBX, GLB or glTF clips, or folders of them")
    ap.add_argument("-o", "--output", type=Path, required=True, help="output folder")
    ap.add_argument("--method", choices=["diffusion", "park", "stgcn"], default="diffusion",
                    help="diffusion: a learned style file (default); park: Park et al. 2021, style from a domain "
                         "(stgcn: its older name)")
    ap.add_argument("--domain", help="park: target style domain (active, elderly, exhausted, feminine, masculine, normal, youthful)")
    ap.add_argument("--variants", type=int, default=1, help="park: outputs from this many noise draws (seeds seed, seed+1, ...)")
    ap.add_argument("--reference", type=Path, help="park: take the style code from this clip (read as --domain)")
    ap.add_argument("--mix", help="park: interpolate towards another domain or another seed (integer)")
    ap.add_argument("--mix-steps", type=int, default=5, help="park: interpolation outputs, ends included (default: %(default)s)")
    ap.add_argument("--park-weights", "--weights", dest="park_weights", type=Path,
                    help="park: its weights (default: the shipped park_stylizer.safetensors; --weights: the older name)")
    from video2style.options import add_apply_options

    add_apply_options(ap)  # the options batch takes too, from this one definition
    _add_device(ap)
    ap.set_defaults(func=cmd_apply)

    po = sub.add_parser("pose", help="video of one person -> BVH on the canonical skeleton (+ preview)",
                        epilog="example: video2style pose walk.mp4 -o walk.bvh --preview walk_pose.mp4")
    po.add_argument("video", type=Path, help="a video of one person (mp4, mov, avi, mkv, webm)")
    po.add_argument("-o", "--output", type=Path, help="output .bvh (default: the video's name with .bvh)")
    po.add_argument("--preview", type=Path, help="also write an mp4: landmarks on the frames beside the fitted skeleton")
    po.add_argument("--cutoff", type=_cutoff, default=3.0, help="Butterworth low-pass cutoff in Hz, 0 = off (default: %(default)s)")
    po.add_argument("--fov", type=_fov, default=60.0, help="assumed horizontal field of view in degrees (default: %(default)s)")
    po.add_argument("--trajectory", default="auto", help="root path from foot contacts, the camera model, or auto (default)")
    po.add_argument("--start", type=float, help="lift the video from this time on, in seconds")
    po.add_argument("--end", type=float, help="lift the video up to this time, in seconds")
    _add_rotate(po)
    po.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    po.set_defaults(func=cmd_pose)

    b = sub.add_parser("batch", help="learn (or reuse) each style and apply it to a BVH/FBX library (resumable)",
                       epilog="examples:\n  video2style batch videos/ --content library/ -o results/\n"
                              "  video2style batch old.v2s strut.mp4 proud.bvh --content library/ -o results/ --tempo auto\n\n"
                              "Style sources may be mixed: videos, BVH/FBX/GLB/glTF example clips and style files from\n"
                              "`video2style learn` (used as they are, not learned again); a folder gives its videos and\n"
                              "style files. The apply options mean what they mean for `video2style apply`.",
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    b.add_argument("inputs", type=Path, nargs="+", metavar="STYLE",
                   help="videos, example clips (.bvh, .fbx, .glb, .gltf), style files (.v2s), or folders of videos "
                        "and style files")
    b.add_argument("--content", type=Path, required=True, help="folder of BVH (or FBX, GLB, glTF) clips, searched recursively; "
                   "FBX/glTF results keep their format unless --format")
    b.add_argument("-o", "--output", type=Path, required=True, help="output folder: styles/, one folder per style, index.html")
    from video2style.options import add_apply_options

    add_apply_options(b)  # apply's options, from its own definition
    b.add_argument("--ray", nargs="?", const="local", metavar="ADDRESS",
                   help="run on Ray (pip install \"video2style[ray]\"): alone, a local Ray on this machine; "
                        "auto or ray://host:port joins a cluster (OUT must then be a folder every node sees)")
    b.add_argument("--workers", type=_positive_int, help="--ray without an address: CPUs to use (default: all)")
    _add_rotate(b)
    _add_device(b)
    b.set_defaults(func=cmd_batch)

    t = sub.add_parser("train-prior", help="train (or resume) the text-conditioned motion diffusion prior")
    t.add_argument("--data", type=Path, default=default_dataset_dir(), help="dataset cache (default: %(default)s)")
    t.add_argument("--out", type=Path, default=cache_dir() / "runs" / "prior", help="run folder (default: %(default)s)")
    t.add_argument("--max-minutes", type=_positive, default=60.0, help="stop after this long; run again to resume (default: %(default)s)")
    t.add_argument("--max-steps", type=int, default=10**9, help="stop at this many optimiser steps in all (default: %(default)s)")
    for name, typ in [("width", _positive_int), ("layers", _positive_int), ("heads", _positive_int), ("ff", _positive_int),
                      ("batch_size", _positive_int), ("window", _positive_int), ("lr", _finite_positive),
                      ("seed", _style_option("seed")), ("decay_start", _non_negative_int), ("decay_steps", _non_negative_int)]:
        t.add_argument(f"--{name.replace('_', '-')}", dest=name, type=typ, default=None,
                       help="default: see transfer.prior.PriorTrainConfig; a resumed run keeps its own")
    t.add_argument("--precision", choices=["fp32", "bf16"], default=None,
                   help="bf16: the training forward under bfloat16 autocast, 1.6x faster on CPUs with avx512_bf16 "
                        "(default: fp32; a resumed run may change it)")
    t.add_argument("--fk-weight", dest="fk_weight", type=_non_negative, default=None,
                   help="weight of the FK consistency term (the joints the predicted rotations place against the "
                        "clip's joint positions, cm^2); the campaign's last stage: 0.05 (default: 0; a resumed run "
                        "may change it)")
    t.add_argument("--contact-weight", dest="contact_weight", type=_non_negative, default=None,
                   help="weight of the foot-contact term (how far the feet the model says are planted move over the "
                        "ground, (cm/frame)^2, as MDM's) (default: 0; a resumed run may change it)")
    t.add_argument("--derive-positions", dest="derive_positions", action="store_const", const=True, default=None,
                   help="derive the output's joint-position channels from its rotation channels instead of predicting "
                        "them (a resumed run may turn it on)")
    t.add_argument("--val-every", dest="val_every", type=int, default=None,
                   help="steps between validation losses, logged to OUT/val.csv (default: 250; 0: none)")
    _add_exclude_styles(t)
    _add_device(t)
    t.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    t.set_defaults(func=cmd_train_prior)

    e = sub.add_parser("train-encoder", help="train (or resume) the motion-text encoder on top of a trained prior")
    e.add_argument("--data", type=Path, default=default_dataset_dir(), help="dataset cache (default: %(default)s)")
    e.add_argument("--prior", type=Path, required=True, help="the prior's denoiser.safetensors")
    e.add_argument("--out", type=Path, default=cache_dir() / "runs" / "encoder", help="run folder (default: %(default)s)")
    e.add_argument("--max-minutes", type=_positive, default=30.0, help="stop after this long; run again to resume (default: %(default)s)")
    e.add_argument("--max-steps", type=int, default=10**9, help="stop at this many optimiser steps in all (default: %(default)s)")
    for name, typ in [("batch_size", _positive_int), ("window", _positive_int), ("lr", _finite_positive),
                      ("seed", _style_option("seed"))]:
        e.add_argument(f"--{name.replace('_', '-')}", dest=name, type=typ, default=None,
                       help="default: see transfer.motion_encoder.EncoderTrainConfig; a resumed run keeps its own")
    _add_exclude_styles(e)
    _add_device(e)
    e.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    e.set_defaults(func=cmd_train_encoder)

    tp = sub.add_parser("train-park", help="train (or resume) Park et al.'s ST-GCN stylizer on the Bandai-2 styles")
    tp.add_argument("--data", type=Path, default=default_dataset_dir(), help="dataset cache (default: %(default)s)")
    tp.add_argument("--out", type=Path, default=cache_dir() / "runs" / "park", help="run folder (default: %(default)s)")
    tp.add_argument("--weights", type=Path, help="exported weights (default: park_stylizer.safetensors in the run folder; "
                    "name the package's transfer/weights/ file to replace the shipped ones)")
    tp.add_argument("--max-minutes", type=_positive, default=60.0, help="stop after this long; run again to resume (default: %(default)s)")
    tp.add_argument("--max-steps", type=int, default=100_000, help="stop at this many optimiser steps in all (default: %(default)s)")
    tp.add_argument("--threads", type=int, default=0, help="torch threads (default: torch's choice; 1 while other work runs)")
    _add_device(tp)
    for name in ("batch_size", "window", "seed", "ds_decay_steps"):
        tp.add_argument(f"--{name.replace('_', '-')}", dest=name,
                        type={"seed": _style_option("seed"), "ds_decay_steps": int}.get(name, _positive_int),
                        default=None,
                        help="default: see park.train.ParkTrainConfig; a resumed run keeps its own")
    tp.add_argument("--lambda-ds", type=float, default=None,
                    help="weight of the diversity-sensitive loss (default 1, as in the paper)")
    tp.add_argument("--init", type=Path, default=None,
                    help="start a new run from exported weights (G/E/F; D fresh), e.g. to fine-tune with another --lambda-ds")
    tp.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    tp.set_defaults(func=cmd_train_park)

    tc = sub.add_parser("train-classifier", help="train (or resume) an ST-GCN content or style classifier for evaluate")
    tc.add_argument("--target", choices=["content", "style"], required=True, help="what the classifier recognises")
    tc.add_argument("--data", type=Path, default=default_dataset_dir(), help="dataset cache (default: %(default)s)")
    tc.add_argument("--out", type=Path, help="run folder (default: <cache>/runs/classifier_<target>)")
    tc.add_argument("--weights", type=Path, help="exported weights (default: classifier_<target>.safetensors in the run "
                    "folder; name the package's transfer/weights/ file to replace the shipped ones)")
    tc.add_argument("--max-minutes", type=_positive, default=10.0, help="stop after this long; run again to resume (default: %(default)s)")
    tc.add_argument("--max-steps", type=int, default=600, help="stop at this many optimiser steps in all (default: %(default)s)")
    tc.add_argument("--threads", type=int, default=0, help="torch threads, 0 = torch's default (default: %(default)s)")
    _add_device(tc)
    tc.add_argument("--seed", type=_style_option("seed"), default=None, help="random seed (default: the config's)")
    tc.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    tc.set_defaults(func=cmd_train_classifier, run_root=cache_dir() / "runs")

    ev = sub.add_parser("evaluate", help="Bandai-2 transfer protocol (Hu et al. 4.2): FMD, CRA, SRA, foot skating",
                        epilog="examples:\n  video2style evaluate --quick --methods identity park ours\n"
                               "  video2style evaluate --unseen --quick --split val --methods identity ours",
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    ev.add_argument("--data", type=Path, default=default_dataset_dir(), help="dataset cache (default: %(default)s)")
    ev.add_argument("-o", "--out", type=Path, default=Path("eval_out"), help="folder for table.md, rows.json, tradeoff.png")
    ev.add_argument("--quick", action="store_true", help="120 transfers with one example per style (default: full, 3780)")
    ev.add_argument("--methods", nargs="+", default=["identity", "park", "ours"], metavar="METHOD",
                    help=f"some of {', '.join(METHODS)}; older names run as the method they stand for: "
                         f"{', '.join(f'{a} ({b})' for a, b in ALIASES.items())} (default: %(default)s)")
    ev.add_argument("--iterations", type=_style_option("iterations"), help="learning iterations per style example (default: learn's)")
    ev.add_argument("--strengths", type=float, nargs="+", help="run each variant of ours at these --strength values "
                    "(one row each; tradeoff.png draws the curves)")
    ev.add_argument("--style-cache", type=Path, help="keep learned styles in this folder and reuse them in later runs")
    ev.add_argument("--split", choices=["test", "val"], default="test",
                    help="clips to evaluate on: val to choose settings, test to report (default: %(default)s)")
    ev.add_argument("--examples-pool", type=int, help="style examples drawn from this many clips per style (default with an ours method: 1 quick, 3 full; otherwise all)")
    ev.add_argument("--park-weights", "--stgcn-weights", dest="park_weights", type=Path,
                    help="Park stylizer weights for park/park-raw (default: the shipped ones; --stgcn-weights: the "
                         "older name)")
    ev.add_argument("--seed", type=_style_option("seed"), default=0,
                    help="seed for example draws and noise (default: %(default)s)")
    ev.add_argument("--dev-styles", type=Path, metavar="DIR",
                    help="the second unseen-style protocol: the folder holding bandai1-unseen-dev-styles.tar.xz and "
                         "bandai1-seen-styles.tar.xz (five Bandai-1 styles no model saw, each learned from its walk and "
                         "applied to ten neutral actions; hand-feature judges); --strengths S: its first value; "
                         "--methods ours-calibrated: each style calibrated (learn --calibrate)")
    ev.add_argument("--unseen", action="store_true",
                    help="the unseen-style protocol: models trained without three styles (elderly, exhausted, feminine), "
                         "neutral content to those styles and, from the same models, to the others")
    ev.add_argument("--unseen-models", type=Path, metavar="DIR",
                    help="--unseen: the folder with the held-out denoiser.safetensors and motion_encoder.safetensors "
                         "(default: the development weights in evaluation/weights/unseen)")
    ev.add_argument("--groups", nargs="+", choices=("held-out", "seen"), default=["held-out", "seen"],
                    help="--unseen: the target groups to run (default: both)")
    ev.add_argument("--style-words", metavar="WORDS",
                    help="learn every style under these words instead of its name (e.g. qwxz: a name that means "
                         "nothing to the encoders)")
    ev.set_defaults(func=cmd_evaluate)
    return p


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    device_error = _device_error(args)
    if device_error:
        print(f"video2style {args.command}: error: {device_error}", file=sys.stderr)
        return 2
    import signal

    def terminated(signum, frame):  # SIGTERM cleans up like Ctrl-C: temporary files are removed on the way out
        raise Terminated()

    try:
        previous = signal.signal(signal.SIGTERM, terminated)
    except ValueError:  # not the main thread: leave signals alone
        previous = None
    try:
        args.func(args)
    except Terminated:
        print("terminated", file=sys.stderr)
        return 143
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except (CliError, ValueError, FileNotFoundError, RuntimeError) as e:
        from motioncore.text import printable
        from video2style.interchange import named

        print(f"video2style {args.command}: error: {printable(named(args, str(e)))}", file=sys.stderr)
        return 1
    except OSError as e:  # a full or read-only disk, a vanished folder: one line naming the path
        from motioncore.text import printable

        where = f"{e.filename}: " if e.filename else ""
        print(f"video2style {args.command}: error: {printable(f'{where}{e.strerror or e}')}", file=sys.stderr)
        return 1
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        if getattr(args, "clip_converter", None) is not None:  # Blender ended, temporary BVH files removed
            args.clip_converter.close()
    return 0


def console_main() -> int:
    """The ``video2style`` console script: :func:`main`, then ``gc.freeze()`` so that the interpreter's exit
    skips a last garbage-collection sweep over every object the imports made (torch's are most of them):
    0.3-0.4 s less at the end of each command on the 2-core box (docs/RESULTS.md, "The first hour").
    Cleanup still runs (atexit handlers, open files flushed); only objects the process never frees are left
    to the operating system. Tests call :func:`main`, which leaves the collector alone."""
    import gc

    try:
        return main()
    finally:
        gc.freeze()


if __name__ == "__main__":
    sys.exit(console_main())
