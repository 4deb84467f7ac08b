"""The packages (the rest of the metadata is in pyproject.toml): the repository's top-level ``samples/`` installs as
``video2style/samples/``, where ``video2style demo`` finds it, in a wheel and in an editable install alike."""
from setuptools import find_namespace_packages, setup

setup(packages=find_namespace_packages(include=["motioncore*", "mlcore*", "lifting*", "transfer*", "park*", "evaluation*",
                                                "video2style*"]) + ["video2style.samples"],
      package_dir={"video2style.samples": "samples"})
