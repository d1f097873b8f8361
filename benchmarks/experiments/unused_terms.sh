#!/usr/bin/env bash
# "Unused terms cost nothing", measured: the same scene is run in this build and
# in a build whose source has the optional terms deleted (every test of a
# feature, `(F & kTerm) != 0`, becomes `false` in the methods' steps), and
# the instructions per step are counted with valgrind's callgrind (repeatable,
# unlike wall time on a shared machine). Both builds are baseline x86-64
# (SPHFLUID_NATIVE=OFF): valgrind 3.19 cannot run AVX-512 code.
#
#   bash benchmarks/experiments/unused_terms.sh          # about 5 minutes on 2 cores
set -euo pipefail
repo="$(cd "$(dirname "$0")/../.." && pwd)"
work="$(mktemp -d)"
py="$(python -c 'import sys; print(sys.executable)')"
pyb="$(python -c 'import pybind11; print(pybind11.get_cmake_dir())')"

build() {  # build NAME SED-EXPRESSION
  mkdir -p "$work/src_$1" "$work/pkg_$1"
  (cd "$repo" && git ls-files | tar -cf - -T - | tar -xf - -C "$work/src_$1")
  [ -n "$2" ] && sed -i "$2" "$work/src_$1/cpp/methods/seed/seed.cpp" "$work/src_$1/cpp/methods/wcsph/wcsph.cpp"
  cmake -S "$work/src_$1" -B "$work/b_$1" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DSPHFLUID_NATIVE=OFF -Dpybind11_DIR="$pyb" -DSKBUILD_PROJECT_NAME=sphfluid \
    -DSKBUILD_PROJECT_VERSION=0 > "$work/cmake_$1.log"
  ninja -C "$work/b_$1" > "$work/ninja_$1.log"
  cp -r "$repo/python/sphfluid" "$work/pkg_$1/"
  cp "$work"/b_"$1"/_core*.so "$work/pkg_$1/sphfluid/"
}
build full ""
build lean 's/(F \& kSurfaceTension) != 0/false/g; s/(F \& kViscosity) != 0/false/g; s/(F \& kWalls) != 0/false/g'

cat > "$work/run.py" <<'PY'
import os, sys
sys.meta_path[:] = [f for f in sys.meta_path if "ScikitBuild" not in type(f).__name__]
sys.path.insert(0, os.environ["PKG"])
from sphfluid.bench import dam_break_scene
from sphfluid.bench_suite import bare_scene
from sphfluid.simulation import Simulation
kind, method, steps = sys.argv[1], sys.argv[2], int(sys.argv[3])
scene = bare_scene(10000, method) if kind == "bare" else dam_break_scene(10000, method)
if kind == "dam":
    scene["fluid"]["surface_tension"] = 0.0
Simulation(scene, threads=1).step(steps)
PY

count() {  # count PKG KIND METHOD STEPS -> instructions of the whole process
  # (a fixed hash seed: with random ones the count varies by up to 2 % a run)
  PYTHONHASHSEED=0 PKG="$work/pkg_$1" OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 valgrind --tool=callgrind \
    --callgrind-out-file=/dev/null "$py" "$work/run.py" "$2" "$3" "$4" 2>&1 |
    sed -n 's/.*Collected : \([0-9]*\).*/\1/p'
}
# The dam break with sigma = 0 needs the lean build's walls and viscosity, so it
# is compared against a build without the tension code only; the bare loop
# against the build without all three.
build notension 's/(F \& kSurfaceTension) != 0/false/g'
for case in "dam seed notension" "dam wcsph notension" "bare seed lean" "bare wcsph lean"; do
  set -- $case
  per_step() { echo $(( ($(count "$1" "$2" "$3" 25) - $(count "$1" "$2" "$3" 5)) / 20 )); }
  a=$(per_step full "$1" "$2"); b=$(per_step "$3" "$1" "$2")
  python -c "print(f'$1 $2: {$a:,} instructions per step with every term compiled, {$b:,} without the unused ones ({100 * ($a - $b) / $b:+.2f} %)')"
done
rm -rf "$work"
