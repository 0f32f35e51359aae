#!/usr/bin/env bash
# What the live previews cost a render (docs/preview.md, "Cost").
#   scripts/preview_overhead.sh [CG_WIDTH] [CG_SPP] [WIDTH] [SPP] [THREADS] [REPEATS]
# 1. Instructions (valgrind --tool=callgrind, one render thread, all threads counted): the built-in Cornell box
#    without a display, with --display-server to a stub viewer that reads and discards, and
#    with --serve polled by a client fetching /status and /image.png four times a second.
#    Under callgrind a pass takes far longer than the 250 ms update interval, so every pass is
#    copied and sent: the worst case.
# 2. Wall time: the same three runs at full speed, alternated REPEATS times, samples/s as
#    lucent reports it.
set -euo pipefail
cgw=${1:-64}; cgspp=${2:-16}; ww=${3:-256}; wspp=${4:-32}; threads=${5:-2}; reps=${6:-3}
bin=${LUCENT:-target/release/lucent}
out=${OUT:-/tmp/preview_overhead}
mkdir -p "$out"
port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
# A stub tev: accept connections, read and discard.
python3 - "$port" <<'PY' &
import socket, sys, threading
srv = socket.socket(); srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
srv.bind(("127.0.0.1", int(sys.argv[1]))); srv.listen(8)
def drain(c):
    while c.recv(1 << 20): pass
while True:
    c, _ = srv.accept(); threading.Thread(target=drain, args=(c,), daemon=True).start()
PY
stub=$!
trap 'kill $stub 2>/dev/null || true' EXIT
sleep 0.5
# A page client: polls status and fetches the image while the render runs (background).
poll() { # url
  python3 - "$1" > /dev/null 2>&1 <<'PY' &
import sys, time, urllib.request
url = sys.argv[1]
while True:
    try:
        urllib.request.urlopen(url + "status", timeout=2).read()
        urllib.request.urlopen(url + "image.png?exposure=0", timeout=2).read()
    except Exception:
        pass
    time.sleep(0.25)
PY
  echo $!
}
render() { # label prefix-command... -- extra args
  local label=$1; shift
  local pre=()
  while [ "$1" != "--" ]; do pre+=("$1"); shift; done; shift
  "${pre[@]}" "$bin" render --width "$w" --height "$w" --spp "$spp" --threads "$threads" --out "$out/$label.pfm" "$@" 2> "$out/$label.log" > /dev/null
}
serve_run() { # label prefix-command...
  local label=$1; shift
  local sport
  sport=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
  local p
  p=$(poll "http://127.0.0.1:$sport/")
  render "$label" "$@" -- --serve "127.0.0.1:$sport"
  kill "$p" 2>/dev/null || true
}
w=$cgw; spp=$cgspp; wthreads=$threads; threads=1
echo "== instructions (callgrind, ${w}x${w}, $spp spp, $threads thread(s))"
cg=(valgrind --tool=callgrind --callgrind-out-file=/dev/null)
for label in none tev serve; do
  case $label in
    none) render cg-none "${cg[@]}" -- ;;
    tev) render cg-tev "${cg[@]}" -- --display-server "127.0.0.1:$port" ;;
    serve) serve_run cg-serve "${cg[@]}" ;;
  esac
  printf '%-6s %s\n' "$label" "$(grep -o 'Collected : [0-9]*' "$out/cg-$label.log" | awk '{print $3}')"
done
w=$ww; spp=$wspp; threads=$wthreads
echo "== wall time (${w}x${w}, $spp spp, $threads thread(s); Msamples/s as lucent reports it), $reps rounds"
for r in $(seq "$reps"); do
  for label in none tev serve; do
    case $label in
      none) render "t-$label" env -- ;;
      tev) render "t-$label" env -- --display-server "127.0.0.1:$port" ;;
      serve) serve_run "t-$label" env ;;
    esac
    printf '%-6s %s\n' "$label" "$(grep -o '[0-9.]* Msamples/s' "$out/t-$label.log")"
  done
done
