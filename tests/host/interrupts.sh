#!/usr/bin/env bash
# Host-side checks of container/run (the sandbox cannot start a sandbox, so these run on the host; .ci/run and
# `make test-host` call this script):
#  1. paths: run from a directory outside the repository, --out/--scene under /tmp, --out=~/..., a relative
#     ../ path and `python` (not python3) under mpirun: the results exist on the host afterwards;
#  2. interrupts: SIGINT to the process group (Ctrl-C) and SIGTERM to container/run end a 2-rank run within a
#     few seconds with a non-zero status, and no process of the run (bwrap, mpirun, python3, Xvfb) is left;
#  3. the same signals keep an interrupted load path's completed solves (OUT.interrupted) and say so.
set -euo pipefail
run=$(cd "$(dirname "$0")/../.." && pwd)/container/run
work=$(mktemp -d /tmp/fenics-coulomb-host-XXXXXX)
home_out="$HOME/.fenics-coulomb-host-test-$$"
trap 'rm -rf "$work" "$home_out"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

# -- 1. paths as the host sees them ---------------------------------------------------------------------
mkdir -p "$work/cwd/sub"
cd "$work/cwd/sub"
printf '[body]\nlev = 0\n' > "$work/scene.toml"
"$run" mpirun -n 2 python -m fenics_coulomb --scene "$work/scene.toml" --out "$work/tmp-out" --quiet --no-plots
[ -s "$work/tmp-out/summary.json" ] || fail "--out under /tmp: no summary.json on the host"
"$run" python3 -m fenics_coulomb --lev 0 --out="$home_out" --quiet --no-plots
[ -s "$home_out/summary.json" ] || fail "--out=~/...: no summary.json in the host's home"
"$run" python3 -m fenics_coulomb --lev 0 --out ../../rel-out --quiet --no-plots
[ -s "$work/rel-out/summary.json" ] || fail "--out ../../rel-out: no summary.json on the host"
status=0
"$run" python3 -m fenics_coulomb --lev 0 --out "" --quiet 2> "$work/err" || status=$?
[ "$status" -eq 2 ] && [ "$(wc -l < "$work/err")" -eq 1 ] || fail "--out '': status $status, $(cat "$work/err")"
echo "paths: ok"

# -- 2. interrupts --------------------------------------------------------------------------------------
for sig in INT TERM; do
    out="$work/int-$sig"
    setsid "$run" mpirun -n 2 python3 -m fenics_coulomb --lev 6 --out "$out" > "$work/log-$sig" 2>&1 &
    pid=$!
    for _ in $(seq 600); do grep -q '^it ' "$work/log-$sig" && break; sleep 0.1; done
    grep -q '^it ' "$work/log-$sig" || fail "SIG$sig: the run did not reach the Newton iteration: $(cat "$work/log-$sig")"
    procs=$(ps -s "$pid" -o args= | grep -c -E 'mpirun|prterun|fenics_coulomb|Xvfb' || true)
    [ "$procs" -ge 4 ] || fail "SIG$sig: expected mpirun, 2 ranks and Xvfb running, found $procs"
    t0=$(date +%s%N)
    if [ "$sig" = INT ]; then kill -INT -- "-$pid"; else kill -TERM "$pid"; fi
    status=0
    wait "$pid" || status=$?
    ms=$((($(date +%s%N) - t0) / 1000000))
    [ "$status" -ne 0 ] || fail "SIG$sig: container/run exited 0"
    [ "$ms" -lt 10000 ] || fail "SIG$sig: took $ms ms"
    left=""
    for _ in $(seq 50); do
        left=$(ps -s "$pid" -o stat=,pid=,args= | awk '$1 !~ /^Z/' || true)
        [ -z "$left" ] && break
        sleep 0.1
    done
    [ -z "$left" ] || fail "SIG$sig: processes left behind:
$left"
    echo "SIG$sig: status $status after $ms ms, no process left"
done
# -- 3. an interrupted load path keeps its completed solves through container/run ------------------------
# bwrap used to die of Ctrl-C at once, and its end SIGKILLs the sandbox (its PID namespace): mpirun never passed
# the signal on, the ranks never kept their solves (a hidden .OUT.partial-* left, exit 130 from bwrap, no line).
# SIGTERM to container/run used to do the same. Now the command inside gets the signal as without the sandbox.
# Ctrl-C is typed into a terminal of the run's own (script(1), whose input is a FIFO), as a user does, with SIGINT
# at its default: a background job of this script has it ignored, and so would every process of the run — bwrap
# too, which then did not die of it, and the check proved nothing.
for sig in INT TERM; do
    out="$work/path-$sig"
    log="$work/path-log-$sig"
    command=("$run" mpirun -n 2 python3 -m fenics_coulomb --lev 4 --steps 200 --pc none --out "$out" --no-plots)
    if [ "$sig" = INT ]; then
        mkfifo "$work/keys"
        setsid env --default-signal=INT script -qefc "$(printf '%q ' "${command[@]}")" /dev/null < "$work/keys" > "$log" 2>&1 &
        pid=$!
        exec 5> "$work/keys"
    else
        setsid "${command[@]}" > >(cat > "$log") 2>&1 &  # a pipe, as `| tee log`: the interrupt's line reaches it
        pid=$!
    fi
    for _ in $(seq 900); do grep -q '^solve 3/200' "$log" && break; sleep 0.1; done
    grep -q '^solve 3/200' "$log" || fail "path SIG$sig: the path did not reach its third solve: $(tail -5 "$log")"
    if [ "$sig" = INT ]; then printf '\003' >&5; else kill -TERM "$pid"; fi
    status=0
    wait "$pid" || status=$?
    [ "$sig" = INT ] && exec 5>&- && rm -f "$work/keys"
    [ "$status" -ne 0 ] || fail "path SIG$sig: container/run exited 0"
    for _ in $(seq 50); do grep -q 'are kept in' "$log" && break; sleep 0.1; done  # the pipe's reader may lag
    [ -s "$out.interrupted/summary.json" ] || fail "path SIG$sig: no $out.interrupted/summary.json: $(tail -5 "$log")"
    grep -q "completed solve(s) of the path are kept in $out.interrupted" "$log" ||
        fail "path SIG$sig: no line naming $out.interrupted: $(tail -5 "$log")"
    leftover=$(find "$work" -maxdepth 1 -name ".path-$sig*")
    [ -z "$leftover" ] || fail "path SIG$sig: left behind: $leftover"
    echo "path SIG$sig: status $status, the completed solves kept in $out.interrupted"
done
# -- 4. container/run passes signals on as the command would take them -----------------------------------
# A signal to container/run's process alone (kill PID, Popen.send_signal) reaches the command: SIGINT, SIGQUIT
# and SIGHUP were ignored (the command ran on) once bwrap ignored them.
for sig in INT QUIT HUP TERM; do
    env --default-signal=INT,QUIT setsid "$run" sleep 30 & pid=$!
    sleep 1
    kill -"$sig" "$pid"
    status=0
    timeout 10 tail --pid="$pid" -f /dev/null || fail "SIG$sig to container/run's pid: still running 10 s later"
    wait "$pid" || status=$?
    [ "$status" -eq $((128 + $(kill -l "$sig"))) ] || fail "SIG$sig to container/run's pid: status $status"
done
# Dispositions ignored on entry stay ignored in the command (nohup's SIGHUP); the others are the defaults.
ignored=$( (trap '' HUP; env --default-signal=INT,QUIT,TERM "$run" sed -n 's/^SigIgn:[[:space:]]*//p' /proc/self/status) )
# of HUP (1), INT (2), QUIT (3) and TERM (15): HUP alone (other bits are the caller's, e.g. a CI runner's)
[ $(( 16#$ignored & 0x4007 )) -eq 1 ] || fail "the command's ignored signals: $ignored, expected SIGHUP of these four"
# Ctrl-C stops a shell loop around container/run, as it does around the command itself: container/run ends by
# the signal the command ended by (it exited 130, and bash went on with the loop).
loop='for i in 1 2 3; do '"$(printf '%q' "$run")"' sleep 5; echo "iteration $i"; done'
mkfifo "$work/keys"
setsid env --default-signal=INT script -qefc "bash -c $(printf '%q' "$loop")" /dev/null < "$work/keys" \
    > "$work/loop-log" 2>&1 &
pid=$!
exec 5> "$work/keys"
sleep 2
printf '\003' >&5
wait "$pid" || true
exec 5>&-
! grep -q iteration "$work/loop-log" || fail "Ctrl-C did not stop the loop: $(cat "$work/loop-log")"
# A signal a process sends to container/run alone while it is in its terminal's foreground group (timeout
# --foreground, a test harness started from a terminal) reaches the command too: it was taken for the terminal's.
SECONDS=0
status=0
setsid env --default-signal=INT script -qefc "timeout --foreground -s INT 3 $(printf '%q' "$run") sleep 30" /dev/null \
    < /dev/null > "$work/fg-log" 2>&1 || status=$?
[ "$SECONDS" -lt 15 ] || fail "timeout --foreground -s INT: container/run ran ${SECONDS} s (status $status)"
# Ctrl-Z, fg and Ctrl-C in an interactive shell on a terminal, end to end: the run goes on after fg and the
# Ctrl-C keeps its solves. mpirun stops its ranks (process groups of their own) and may leave them stopped after
# fg — a hostile review's terminal driven from Python saw the run hang, and a Ctrl-C then let it run to its end;
# container/run's watcher continues them (this script(1) terminal does not reproduce the hang on the code before).
# Signals sent by this script would not do: a group without a terminal is orphaned, and SIGTSTP does not stop it.
out="$work/tstp"
mkfifo "$work/tstp-keys"
setsid env --default-signal=INT script -qefc "bash --norc --noprofile -i" /dev/null < "$work/tstp-keys" \
    > "$work/tstp-log" 2>&1 &
pid=$!
exec 5> "$work/tstp-keys"
printf '%s\n' "$(printf '%q ' "$run" mpirun -n 2 python3 -m fenics_coulomb --lev 4 --steps 200 --pc none --out "$out" \
    --no-plots)" >&5
for _ in $(seq 900); do grep -q 'solve 3/200' "$work/tstp-log" && break; sleep 0.1; done
printf '\032' >&5  # Ctrl-Z
sleep 2
before=$(grep -c 'solve .*/200' "$work/tstp-log" || true)  # the solves done before the stop, at most
printf 'fg\n' >&5
sleep 4  # mpirun relays the ranks' output late after a stop: count the solves kept, not the lines shown
printf '\003' >&5
for _ in $(seq 100); do grep -q 'are kept in' "$work/tstp-log" && break; sleep 0.1; done
printf 'exit\n' >&5
exec 5>&-
timeout 30 tail --pid="$pid" -f /dev/null || kill -KILL -- "-$pid"
wait "$pid" || true
rm -f "$work/tstp-keys"
[ -s "$out.interrupted/summary.json" ] || fail "Ctrl-Z, fg, Ctrl-C: no $out.interrupted: $(tail -3 "$work/tstp-log")"
kept=$(grep -o '"completed": [0-9]*' "$out.interrupted/summary.json" | grep -o '[0-9]*$')
[ "$kept" -gt $((before + 5)) ] || fail "Ctrl-Z, fg: $kept solves kept, $before before the stop: the ranks stayed stopped"
echo "signals to container/run: ok"
echo "container/run host checks: ok"
