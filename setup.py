"""The compiled haptic core (server/core/haptics/_chaptics.c), built by `pip install -e .`.

-ffp-contract=off and no -ffast-math: the C must round exactly like Python's doubles, operation
for operation, so its results equal the Python reference's (tests/haptics/test_compiled.py).
"""

from setuptools import Extension, setup

setup(ext_modules=[Extension(
    "server.core.haptics._chaptics", ["server/core/haptics/_chaptics.c"],
    extra_compile_args=["-O2", "-std=c11", "-ffp-contract=off", "-fno-fast-math", "-Wall", "-Wextra",
                        "-Wno-missing-field-initializers"],
)])
