"""``video2style batch --ray``: the same batch as :mod:`video2style.batch`, spread over a Ray cluster.

Work units: one task per video's ``learn`` (about a minute of CPU), then, as each style lands, one task
per chunk of clips to ``apply`` it to (many short items per task, so scheduling does not dominate).
Each worker process loads the models once (:func:`transfer.bundle.load_models` is cached per
process) and runs torch on cores / workers threads (one on a cluster), so workers × threads never
exceed the cores.
Style files go to ``OUT/styles`` and reach the apply tasks by that path: on several machines ``OUT``
must be a folder they all see (NFS, a mounted bucket). Every file is written atomically, an item is
done only when its BVH and preview both exist, a failing item is tried ``retries`` more times and then
reported, and a task whose worker dies is run again by Ray (what it finished is skipped).
With ``--device cuda`` (or ``auto`` where there are GPUs: :func:`task_device`) each learn and apply task asks
Ray for one GPU (:func:`task_options`) and its worker runs the models on the GPU Ray gives it.
"""
from __future__ import annotations

import os
import socket
import time
from pathlib import Path

from mlcore.device import DEVICES, resolve_device
from video2style.batch import (
    BatchReport,
    apply_item,
    batch_folder,
    plan,
    style_path,
    write_index,
    write_report,
)
from video2style.options import ApplyOptions


def _worker() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def task_device(device: str, cluster_gpus: float | None) -> str:
    """Where the learn and apply tasks run for ``--device`` (``auto``, ``cpu``, ``cuda``): ``"cuda"`` or ``"cpu"``.

    ``cluster_gpus`` None (a local Ray): what ``device`` resolves to on this machine
    (:func:`mlcore.device.resolve_device`). On a cluster, the GPUs Ray counts decide: cuda for ``cuda`` (a
    ValueError when there are none: its tasks would wait forever) and for ``auto`` when there are some.
    """
    if cluster_gpus is None:
        return resolve_device(device).type
    if device not in DEVICES:
        raise ValueError(f"--device: expected one of {', '.join(DEVICES)}, got {device!r}")
    if device == "cuda" and cluster_gpus <= 0:
        raise ValueError("--device cuda: the Ray cluster has no GPU (ray.cluster_resources() counts none); "
                         "use --device cpu or auto")
    return "cuda" if device == "cuda" or (device == "auto" and cluster_gpus > 0) else "cpu"


def task_options(device: str) -> dict:
    """Ray options of a learn or apply task on ``device`` (from :func:`task_device`): one CPU, run again up to
    three times if its worker dies, and one GPU for ``"cuda"`` (Ray then shows the worker that GPU alone)."""
    if device not in ("cpu", "cuda"):
        raise ValueError(f"task_options: expected 'cpu' or 'cuda', got {device!r}")
    return {"num_cpus": 1, "max_retries": 3, **({"num_gpus": 1} if device == "cuda" else {})}


def _learn_job(video: str, style_file: str, learn_config, threads: int, device: str = "cpu",
               rotate: int | None = None) -> dict:
    """Load or learn one video's style (runs in a Ray worker, on ``device``)."""
    import torch

    from video2style.batch import _style_for

    torch.set_num_threads(threads)
    t0 = time.time()
    try:
        _style_for(Path(video), Path(style_file), "", learn_config, lambda s: None, device, rotate)
        return {"video": Path(video).name, "status": "learned", "seconds": time.time() - t0, "worker": _worker()}
    except Exception as e:  # noqa: BLE001 - reported as the video's failure
        return {"video": Path(video).name, "status": "failed", "error": f"{'style' if video.lower().endswith('.v2s') else 'learn'}: {e}", "seconds": time.time() - t0,
                "worker": _worker()}


def _apply_job(video: str, style_file: str, items: list[tuple[str, str]], options, retries: int, threads: int,
               device: str = "cpu") -> list[dict]:
    """Apply one style to a chunk of ``(clip, output folder)`` items (runs in a Ray worker, on ``device``)."""
    import torch

    from video2style.loaded_style import LoadedStyle

    torch.set_num_threads(threads)
    style = LoadedStyle.from_file(style_file, device=device)
    return [{**apply_item(style, video, Path(clip), Path(where), options, retries), "worker": _worker()}
            for clip, where in items]


def run_batch_ray(inputs, content_dir: Path, out_dir: Path, options: ApplyOptions = ApplyOptions(), learn_config=None,
                  address: str | None = None, workers: int | None = None, chunk: int = 8, retries: int = 1,
                  progress=print, device: str = "cpu", rotate: int | None = None) -> BatchReport:
    """:func:`video2style.batch.run_batch` on Ray (``options``: the apply request). ``address``: None starts a local Ray with ``workers``
    CPUs (default: all), ``"auto"`` or ``"ray://host:port"`` joins a cluster. Writes ``index.html`` and
    ``report.json`` (one row per item: status, seconds, worker, attempts, error). ``device``: where the
    tasks run (:func:`task_device`; a GPU task asks Ray for one GPU)."""
    try:
        import ray
    except ImportError:
        raise RuntimeError('batch --ray needs Ray: pip install "video2style[ray]"') from None
    from tqdm import tqdm

    out_dir = Path(out_dir)
    videos, clips, keys = plan(inputs, content_dir, out_dir, progress)
    with batch_folder(out_dir, progress):
        started_here = not ray.is_initialized()
        on = task_device(device, None) if address is None else None  # a local Ray: this machine's torch decides
        if started_here:
            import torch

            ray.init(address=address, num_cpus=workers if address is None else None, include_dashboard=False,
                     log_to_driver=False, configure_logging=False,
                     num_gpus=torch.cuda.device_count() if on == "cuda" else None)
        try:
            on = on or task_device(device, ray.cluster_resources().get("GPU", 0))
            # torch threads per task: the machine's cores shared by the tasks Ray runs at once on it
            threads = max(1, (os.cpu_count() or 1) // max(1, int(workers or os.cpu_count() or 1))) if address is None else 1
            learn = ray.remote(_learn_job).options(**task_options(on))
            apply = ray.remote(_apply_job).options(**task_options(on))
            pending = {learn.remote(str(v), str(style_path(v, keys[v], out_dir)), learn_config, threads, on, rotate):
                       ("learn", v) for v in videos}
            report = BatchReport()
            bar = tqdm(total=len(videos) * (1 + len(clips)), unit="item", desc="batch", disable=progress is None)
            while pending:
                done, _ = ray.wait(list(pending), num_returns=1)
                kind, what = pending.pop(done[0])
                result = ray.get(done[0])
                if kind == "learn":
                    bar.update(1)
                    if result["status"] == "failed":
                        report.add(**result)
                        bar.update(len(clips))
                        continue
                    style_file = str(style_path(what, keys[what], out_dir))
                    items = [(str(c), str(out_dir / keys[what] / c.relative_to(content_dir).parent)) for c in clips]
                    for i in range(0, len(items), chunk):
                        ref = apply.remote(what.name, style_file, items[i:i + chunk], options, retries, threads, on)
                        pending[ref] = ("apply", len(items[i:i + chunk]))
                else:
                    for row in result:
                        report.add(**row)
                    bar.update(what)
            bar.close()
        finally:
            if started_here:
                ray.shutdown()
        write_index(report, out_dir)
        write_report(report, out_dir)
    return report
