"""Park, Jang, Lee 2021, "Diverse motion stylization for multiple style domains via spatial-temporal
graph-based generative model": an ST-GCN StarGAN-v2-style stylizer over the 7 Bandai-2 style domains.

``networks`` (G, E, F, D), ``losses`` (eq. 7-12), ``train`` (:func:`train_park`), ``infer``
(:func:`load_park`, :func:`stylize_noise`, :func:`stylize_reference`, :func:`mix`, :func:`park_method`).
"""
