#!/bin/bash
# Peak RSS (summed over 2 ranks, getrusage from outside: benchmarks/peak_rss.py of main, copied to /tmp/mf)
# of the contact solve with the matrix-free Newton operator, with the explicit copy (--no-matrix-free)
# and of the linear-elastic reference (benchmarks/elastic.py of main, a copy of main in /tmp/mf/main),
# d3/L2, default settings. Written before the API branch reached main (scale.py could not run here yet).
# usage: benchmarks/matfree_memory.sh LEV...   (results in /tmp/mf/res, log in /tmp/mf/res/log)
cd /tmp/mf
R=/work/wt-matfree/container/run
for lev in "$@"; do
  for job in matfree explicit linear; do
    d=/tmp/mf/res/lev$lev-$job; rm -rf $d; mkdir -p $d
    echo "$(date -u +%T) start lev $lev $job $(cat /proc/loadavg)" >> /tmp/mf/res/log
    t0=$(date +%s.%N)
    case $job in
      matfree) $R mpirun -n 2 python3 /tmp/mf/peak_rss.py $d -- python3 -m fenics_coulomb --lev $lev --gap d3 --load L2 --no-plots --quiet --out $d/out > $d/stdout 2> $d/stderr ;;
      explicit) $R mpirun -n 2 python3 /tmp/mf/peak_rss.py $d -- python3 -m fenics_coulomb --lev $lev --gap d3 --load L2 --no-plots --quiet --no-matrix-free --out $d/out > $d/stdout 2> $d/stderr ;;
      linear) $R env PYTHONPATH=/tmp/mf/main mpirun -n 2 python3 /tmp/mf/peak_rss.py $d -- python3 /tmp/mf/main/benchmarks/elastic.py --lev $lev --case d3/L2 --out $d/out > $d/stdout 2> $d/stderr ;;
    esac
    rc=$?
    t1=$(date +%s.%N)
    echo "$(date -u +%T) end lev $lev $job rc=$rc wall=$(echo "$t1 - $t0" | bc) rss=$(cat $d/rss-*.json | python3 -c 'import sys,json; print(sum(json.loads(l)["peak_rss_kib"] for l in sys.stdin)/1024)') MiB load $(cat /proc/loadavg)" >> /tmp/mf/res/log
  done
done
