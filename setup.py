"""Build of the Python module meshreduce for pip (pyproject.toml).

The C extension meshreduce._core is built by the project's CMake build
(target meshreduce_python), so it is compiled with exactly the library's
flags (-ffp-contract=off and the rest) and linked with its static library:
results are the CLI's bytes. CMake gets this interpreter
(Python3_EXECUTABLE=sys.executable); MESHREDUCE_CMAKE_ARGS adds options
(e.g. "-DMR_OPENMP=OFF").
"""

import glob
import os
import shlex
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = os.path.dirname(os.path.abspath(__file__))


class CMakeExtension(Extension):
    def __init__(self, name):
        super().__init__(name, sources=[])


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build_dir = os.path.abspath(os.path.join(self.build_temp, "cmake"))
        configure = [
            "cmake", "-S", ROOT, "-B", build_dir,
            "-DCMAKE_BUILD_TYPE=Release",
            "-DMR_BUILD_TESTS=OFF", "-DMR_BUILD_BENCH=OFF", "-DMR_PYTHON=ON",
            "-DPython3_EXECUTABLE=" + sys.executable,
        ] + shlex.split(os.environ.get("MESHREDUCE_CMAKE_ARGS", ""))
        subprocess.check_call(configure)
        jobs = str(os.cpu_count() or 1)
        subprocess.check_call(["cmake", "--build", build_dir, "--target", "meshreduce_python",
                               "-j", jobs])
        built = glob.glob(os.path.join(build_dir, "python", "meshreduce", "_core*.so"))
        if len(built) != 1:
            raise RuntimeError("meshreduce: CMake built %r, expected one _core*.so" % built)
        dest = self.get_ext_fullpath(ext.name)
        os.makedirs(os.path.dirname(dest), exist_ok=True)
        shutil.copyfile(built[0], dest)


setup(
    packages=["meshreduce"],
    package_dir={"": "python"},
    package_data={"meshreduce": ["__init__.pyi", "py.typed"]},
    ext_modules=[CMakeExtension("meshreduce._core")],
    cmdclass={"build_ext": CMakeBuild},
    # Not build/: that is the CMake build of `make`.
    options={"build": {"build_base": "build-python"}},
    zip_safe=False,
)
