"""Park, Jang, Lee 2021, "Diverse motion stylization for multiple style domains via spatial-temporal
graph-based generative model": an ST-GCN StarGAN-v2-style stylizer over the 7 Bandai-2 style domains,
the project's second method (``video2style apply --method park``, ``train-park``).

``graph`` (the ST-GCN layer on the canonical skeleton, also used by :mod:`evaluation.classifiers`),
``networks`` (G, E, F, D), ``losses`` (eq. 7-12), ``train`` (:func:`train_park`), ``infer``
(:func:`load_park`, :func:`stylize_noise`, :func:`stylize_reference`, :func:`mix` and :func:`mixed_code`, :func:`park_method`).

Imports go one way: motioncore <- mlcore <- park <- evaluation <- video2style; park and transfer are
siblings over mlcore.
"""
