"""Build the ROS 2 interface packages that have no PyPI wheel into the virtual environment:
``tf2_msgs`` (/tf and /tf_static) and ``simulation_interfaces`` (the ROS simulation standard),
from their definitions in ``interfaces/`` (copied from ros2/geometry2 and
ros-simulation/simulation_interfaces, branch jazzy, with their licenses).

Run by ``make venv`` with the venv's Python (``.venv/bin/python tools/build_interfaces.py``).
Each package is generated and compiled with the PyPI rosidl toolchain, cmake and the C and C++
compilers, C and Python type supports only (rclpy needs no C++ ones), and installed into the
venv, whose libraries the ROS wheels already put on the library path. A package already built
from the same definitions is skipped, so a second run does nothing. Without cmake or a compiler
it says what to install in one line and exits 0: the simulator runs without /tf and the
simulation services (the node says so once at start).
"""

import argparse
import hashlib
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCES = ROOT / 'interfaces'
PACKAGES = ('tf2_msgs', 'simulation_interfaces')     # in build order
KINDS = ('msg', 'srv', 'action')
DIGEST_NAME = 'affine_joint_sim.digest'              # in share/<package>: what it was built from
# the wheels were built with a Python and NumPy under this prefix; their CMake exports name it
WHEEL_PYTHON = re.compile(r'/opt/python/cp3\d+-cp3\d+/include/python3\.\d+')
WHEEL_NUMPY = re.compile(r'/opt/python/cp3\d+-cp3\d+/lib/python3\.\d+/site-packages/numpy/'
                         r'_core/include')

CMAKE_LISTS = """cmake_minimum_required(VERSION 3.16)
project({name})
find_package(ament_cmake REQUIRED)
find_package(rosidl_default_generators REQUIRED)
{find_dependencies}
# C and Python type supports only: the C++ generators are left out (rclpy does not use them)
list(FILTER AMENT_EXTENSIONS_rosidl_generate_idl_interfaces EXCLUDE REGEX "_cpp")
rosidl_generate_interfaces(${{PROJECT_NAME}}
  {files}
  DEPENDENCIES {dependencies})
ament_package()
"""


def definitions(name: str) -> list[str]:
    """The package's .msg, .srv and .action files, relative to its folder, sorted."""
    folder = SOURCES / name
    return sorted(str(p.relative_to(folder)) for kind in KINDS
                  for p in (folder / kind).glob(f'*.{kind}'))


def dependencies(name: str) -> list[str]:
    """The package's <depend> entries (package.xml)."""
    root = ET.parse(SOURCES / name / 'package.xml').getroot()
    return [d.text.strip() for d in root.findall('depend')]


def digest(name: str) -> str:
    """A hash of what the build is made from: the definitions, package.xml and the CMake
    project it generates."""
    h = hashlib.sha256(CMAKE_LISTS.encode())
    for rel in [*definitions(name), 'package.xml']:
        h.update(rel.encode() + b'\0' + (SOURCES / name / rel).read_bytes())
    return h.hexdigest()


def built(name: str, prefix: Path) -> bool:
    """Whether the venv holds the package built from these definitions."""
    stamp = prefix / 'share' / name / DIGEST_NAME
    return stamp.is_file() and stamp.read_text().strip() == digest(name)


def missing_tools() -> list[str]:
    """The build tools not found: cmake, a C and a C++ compiler, the Python headers."""
    missing = [tool for tool, names in (('cmake', ['cmake']), ('a C compiler', ['cc', 'gcc']),
                                        ('a C++ compiler', ['c++', 'g++']))
               if not any(shutil.which(n) for n in names)]
    if not (Path(sysconfig.get_paths()['include']) / 'Python.h').is_file():
        missing.append('the Python 3.12 headers (Python.h)')
    return missing


def repoint_wheel_exports(prefix: Path) -> int:
    """Point the ROS wheels' CMake exports at this Python's headers and the venv's NumPy
    (they name the wheel builder's); returns how many files changed."""
    import numpy
    python_include, numpy_include = sysconfig.get_paths()['include'], numpy.get_include()
    changed = 0
    for path in (prefix / 'share').glob('*/cmake/*Export.cmake'):
        text = path.read_text()
        fixed = WHEEL_NUMPY.sub(numpy_include, WHEEL_PYTHON.sub(python_include, text))
        if fixed != text:
            path.write_text(fixed)
            changed += 1
    return changed


def build(name: str, prefix: Path, jobs: int) -> None:
    """Generate, compile and install one package into ``prefix`` (CalledProcessError with
    the tool's output on failure)."""
    files, deps = definitions(name), dependencies(name)
    with tempfile.TemporaryDirectory(prefix=f'{name}-') as work:
        source, binary = Path(work) / 'src', Path(work) / 'build'
        shutil.copytree(SOURCES / name, source)
        (source / 'CMakeLists.txt').write_text(CMAKE_LISTS.format(
            name=name, files='\n  '.join(f'"{f}"' for f in files),
            dependencies=' '.join(deps),
            find_dependencies='\n'.join(f'find_package({d} REQUIRED)' for d in deps)))
        for command in (
                ['cmake', '-S', str(source), '-B', str(binary), f'-DCMAKE_PREFIX_PATH={prefix}',
                 f'-DCMAKE_INSTALL_PREFIX={prefix}', '-DBUILD_TESTING=OFF',
                 f'-DPython3_EXECUTABLE={sys.executable}', '-DCMAKE_BUILD_TYPE=Release'],
                ['cmake', '--build', str(binary), '-j', str(jobs)],
                ['cmake', '--install', str(binary)]):
            subprocess.run(command, check=True, capture_output=True, text=True,
                           env=dict(os.environ, AMENT_PREFIX_PATH=str(prefix)))
    (prefix / 'share' / name / DIGEST_NAME).write_text(digest(name) + '\n')


def main(argv=None) -> int:
    """Build what is not built yet into ``--prefix`` (default: this Python's venv)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--prefix', type=Path, default=Path(sys.prefix),
                        help='where to install (default: %(default)s)')
    prefix = parser.parse_args(argv).prefix
    todo = [name for name in PACKAGES if not built(name, prefix)]
    if not todo:
        return 0
    missing = missing_tools()
    if missing:
        print(f'interfaces: {", ".join(todo)} not built: {", ".join(missing)} missing (Debian '
              'or Ubuntu: apt install cmake g++ python3-dev); the simulator runs without /tf '
              'and the simulation services until `make venv` builds them', file=sys.stderr)
        return 0
    repoint_wheel_exports(prefix)
    for name in todo:
        print(f'interfaces: building {name} ({len(definitions(name))} definitions, C and Python '
              f'type supports) into {prefix} ...', flush=True)
        began = time.monotonic()
        try:
            build(name, prefix, os.cpu_count() or 1)
        except subprocess.CalledProcessError as exc:
            tail = '\n'.join((exc.stdout + exc.stderr).splitlines()[-15:])
            print(f'interfaces: building {name} failed ({" ".join(exc.cmd[:2])}):\n{tail}',
                  file=sys.stderr)
            return 1
        print(f'interfaces: {name} built in {time.monotonic() - began:.0f} s', flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
