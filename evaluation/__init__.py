"""Measuring style transfer, apart from the methods in ``transfer/`` and ``park/``.

- :mod:`evaluation.protocol`: the Bandai-2 transfer protocol after Hu et al. 2024 §4.2 (clip selection,
  FMD, CRA, SRA, foot skating), run by ``video2style evaluate``;
- :mod:`evaluation.metrics` and :mod:`evaluation.classifiers`: the metrics and the ST-GCN content and
  style classifiers behind them (on :mod:`park.graph`, the graph convolution they share with Park et al.).
The prior's and the motion encoder's own evidence of quality is measured by ``benchmarks/eval_prior.py``.

Park et al. 2021's stylizer, the comparison method, is its own package :mod:`park` (users reach it through
``video2style apply --method park``).

Imports go one way: motioncore <- mlcore <- transfer, park <- evaluation <- video2style.
"""
