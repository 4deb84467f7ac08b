"""The project-made demo inputs (four BVH clips and a style video; ``make_samples.py`` remakes them). The folder sits at
the repository's top level and installs as the package ``video2style.samples`` (setup.py's ``package_dir``), so a wheel
and an editable install alike find it with :mod:`importlib.resources` (``video2style.demo.SAMPLES``)."""
