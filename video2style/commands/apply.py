"""``video2style apply``: a learned style (:meth:`video2style.loaded_style.LoadedStyle.apply`) or Park et al.'s stylizer
(:func:`video2style.park_apply.apply_park_file`) applied to clips and folders of clips."""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from video2style.arguments import add_device
from video2style.commands.checks import CliError, writable
from video2style.paths import check_no_links, check_outputs


def add_parser(sub) -> None:
    """The ``apply`` command's parser, on the subparsers ``sub``."""
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
    add_device(ap)
    ap.set_defaults(func=run)


def run(args) -> None:
    from motioncore.retarget import load_joint_map
    from video2style.batch import folder_lock

    joint_map = load_joint_map(args.joint_map) if args.joint_map else None
    writable(args.output, "-o", is_dir=True)
    runner = _park_runner if args.method in ("park", "stgcn") else _diffusion_runner  # stgcn: park's older name
    run_item, files, heading, facts = runner(args, joint_map)
    from video2style.interchange import in_formats

    run_item = in_formats(args, run_item)  # FBX/glTF clips in, results in --format (default: the clip's own)
    with folder_lock(args.output, "apply", [where for _, where in files]):  # two runs into one folder would mix outputs
        _sweep_outputs(where for _, where in files)
        failed, rows = _apply_all(run_item, files)
        if len(rows) > failed:  # a run that made nothing leaves nothing (its errors are printed)
            _apply_pages(rows, args.output, heading, facts, page=not args.no_preview)
    if failed:
        raise CliError(f"{failed} of {len(files)} clips failed (listed above)")


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
            result = run_item(path, where)
        except (ValueError, FileNotFoundError, OSError) as e:
            from motioncore.text import printable

            failed += 1
            print(f"[{i}/{len(files)}] {printable(path)}: error: {printable(e)}", file=sys.stderr)
            rows.append({"clip": path.name, "content": str(path), "status": "failed", "error": printable(e)})
            continue
        outs = result.outputs
        details = clip_details(result)
        print(f"[{i}/{len(files)}] {path} -> {', '.join(outs)}: {details['summary']}")
        rows.append({"clip": path.name, "content": str(path), "status": "done", **details, "output": outs[0],
                     "outputs": outs})
        if result.preview_note:
            print(f"    note: {result.preview_note}", file=sys.stderr)
        if result.stream_note:
            print(f"    note: {result.stream_note}", file=sys.stderr)
    return failed, rows


def _diffusion_runner(args, joint_map):
    """apply with a learned style: ``(run_item(clip, folder) -> ApplyResult, [(clip, folder)], heading, facts)`` for
    the report and the results page."""
    from transfer.style_file import Style
    from video2style.loaded_style import LoadedStyle
    from video2style.options import apply_options

    if args.style is None or args.style.suffix.lower() == ".bvh" or args.style.is_dir():
        raise CliError("apply: the first argument must be a style file from `video2style learn` (or use --method park --domain D)")
    for flag in ("domain", "reference", "mix"):
        if getattr(args, flag) is not None:
            raise CliError(f"apply: --{flag} belongs to --method park")
    options = apply_options(args)  # one line for a bad --strength or --tempo, before the style loads
    style = Style.load(args.style)
    files = _bvh_inputs(args.inputs, args.output, [("the style file", args.style), ("the --joint-map", args.joint_map)],
                        getattr(args, "format", None))
    loaded = LoadedStyle.from_style(style, device=args.device)  # the models, after the checks
    warning = loaded.warning()
    if warning:
        print(warning, file=sys.stderr)
    return ((lambda path, where: loaded.apply(path, where, options, joint_map)), files, args.style.name,
            loaded.describe(options.strength))


def _park_runner(args, joint_map):
    """apply with Park et al.'s stylizer: what :func:`_diffusion_runner` returns."""
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
    return ((lambda path, where: apply_park_file(model, path, where, request, joint_map, not args.no_preview)), files,
            f"park: {args.domain}", f"Park et al.'s stylizer, domain {args.domain}")
