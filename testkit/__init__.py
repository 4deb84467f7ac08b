"""What tests and benchmarks share, and neither owns: synthetic motions and rigs (``motions``, ``rig_corpus``,
``rig_poses``), synthetic BlazePose frames (``synthetic_blazepose``), pose accuracy (``accuracy``), FBX/glTF test
clips (``clips``). Not part of the installed package: run from the repository root."""
