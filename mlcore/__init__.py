"""The machine-learning base both methods stand on (:mod:`transfer`, Hu et al.'s, and :mod:`park`, Park et al.'s)
and that :mod:`evaluation` measures with: the Bandai-Namco motion dataset cache (``dataset``) and its vocabularies
(``captions``), saving and loading models (``checkpoints``), the one training loop (``training``), overlapping
windows over long motions (``windows``), where the models run (``device``), and the shipped weights with their
model cards (``weights/``, found through ``shipped``).

Imports go one way: motioncore <- mlcore <- transfer, park <- evaluation <- video2style.
"""
