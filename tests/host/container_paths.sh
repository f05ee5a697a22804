#!/usr/bin/env bash
# Host-side checks of container/run's paths outside the working directory, the repository, /tmp and the home
# (the sandbox cannot start a sandbox, so this runs on the host), on 1 and 2 ranks:
#  1. rerunning into an existing result set there: the set is written beside itself (a temporary sibling,
#     renamed), so its parent must be writable too (it was "not writable": only the set was bound);
#  2. a scene naming an STL file by an absolute path, and one naming it relative to the scene, both outside every
#     bound directory (they were "no such file").
# The scratch directory is $FENICS_COULOMB_HOST_SCRATCH (default /var/tmp); skipped when it is not writable.
set -euo pipefail
run=$(cd "$(dirname "$0")/../.." && pwd)/container/run
repo=$(cd "$(dirname "$0")/../.." && pwd)
scratch=${FENICS_COULOMB_HOST_SCRATCH:-/var/tmp}
if ! { [ -d "$scratch" ] && [ -w "$scratch" ]; }; then
    echo "container paths: skipped ($scratch is not a writable directory)"
    exit 0
fi
work=$(mktemp -d "$scratch/fenics-coulomb-paths-XXXXXX")
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
cd "$repo"

mkdir -p "$work/sets" "$work/stl" "$work/meshes" "$work/scenes"
"$run" python3 "$repo/meshes/surfaces.py" icosphere "$work/stl/ball.stl" --radius 0.3 --center 1 0.5 1.3 --level 2
cp "$work/stl/ball.stl" "$work/meshes/rel.stl"
scene() { # scene NAME FILE: the block under the STL ball (pressed 0.02 into it), the ball given as FILE
    printf '[body]\nlev = 1\ngap = "0.0*x1"\nclamped = ["bottom"]\ncontact = ["top"]\n[tractions]\n[[obstacle]]\n' \
        > "$work/scenes/$1.toml"
    printf 'type = "surface"\nfile = "%s"\ndisplacement = [0, 0, -0.02]\n' "$2" >> "$work/scenes/$1.toml"
}
scene absolute "$work/stl/ball.stl"
scene relative "../meshes/rel.stl"

for ranks in 1 2; do
    out="$work/sets/out-$ranks"
    for attempt in first rerun; do
        "$run" mpirun -n "$ranks" python3 -m fenics_coulomb --lev 0 --out "$out" --quiet --no-plots \
            > "$work/log" 2>&1 || fail "$ranks rank(s), $attempt run into $out: $(cat "$work/log")"
    done
    [ -s "$out/summary.json" ] || fail "$ranks rank(s): no summary.json in $out"
    ls -a "$work/sets" | grep -q partial && fail "$ranks rank(s): a partial set left in $work/sets"
    for name in absolute relative; do
        "$run" mpirun -n "$ranks" python3 -m fenics_coulomb --scene "$work/scenes/$name.toml" \
            --out "$work/sets/$name-$ranks" --quiet --no-plots > "$work/log" 2>&1 ||
            fail "$ranks rank(s), scene with the STL file $name: $(cat "$work/log")"
        grep -q '"converged": true' "$work/sets/$name-$ranks/summary.json" ||
            fail "$ranks rank(s), $name: not converged"
    done
done
echo "container paths: ok"
