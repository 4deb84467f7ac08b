"""Measuring style transfer, apart from the method in ``transfer/``.

- :mod:`evaluation.protocol`: the Bandai-2 transfer protocol after Hu et al. 2024 §4.2 (clip selection,
  FMD, CRA, SRA, foot skating), run by ``video2style evaluate``;
- :mod:`evaluation.metrics` and :mod:`evaluation.classifiers`: the metrics and the ST-GCN content and
  style classifiers behind them (:mod:`evaluation.stgcn`, the graph convolution they share with Park et al.);
- :mod:`evaluation.prior_eval`: evidence of quality for the prior and the motion encoder;
- :mod:`evaluation.park`: Park et al. 2021's ST-GCN stylizer, the comparison method (users reach it
  through ``video2style apply --method stgcn``).

Imports go one way: motioncore <- transfer <- evaluation <- video2style.
"""
