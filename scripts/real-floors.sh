#!/usr/bin/env bash
# Every planner in worlds traced from four real robots' maps (docs/experiments/real-floor-maps.md):
# the map each corrected CARMEN log leaves (`lives replay --map-out`), a world traced from it
# (`lives worlds --from-map`, starting at the log's first laser pose, ten targets from seed 1),
# then `lives eval` over the four worlds, without and with the known map.
# Usage: scripts/real-floors.sh [OUT_DIR [EVAL_ARGS...]]   (default out/real-floors; EVAL_ARGS go to
# both `lives eval` runs, e.g. `--set lethal_radius_m=0.25`, docs/experiments/soft-clearance.md)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/real-floors}
shift || true
mkdir -p "$out/worlds"
cargo build --release -p host --bin lives -q
lives=target/release/lives
worlds=()
for log in intel aces freiburg-079 csail; do
  file=tests/data/carmen/$log-corrected.log.gz
  "$lives" replay "$file" --map-out "$out/worlds/$log.yaml" > /dev/null
  # Laser poses in log order (x y yaw in degrees): the first one the world accepts as a start.
  # A building larger than a world may be (50 m): the 48 m square around the start.
  window=()
  placed=
  while read -r x y deg; do
    for attempt in 1 2; do
      if "$lives" worlds --from-map "$out/worlds/$log.yaml" --start "$x,$y,$deg" --random-targets 10 --seed 1 \
          --name "$log" "${window[@]}" > "$out/worlds/$log.toml" 2> "$out/worlds/$log.err"; then
        placed="$x,$y,$deg ${window[*]}"
        break 2
      fi
      grep -q "a world holds at most" "$out/worlds/$log.err" && [ ${#window[@]} -eq 0 ] || break
      window=(--window 48)
    done
  done < <(zcat "$file" | awk '$1 == "FLASER" { n = $2; printf "%s %s %.3f\n", $(3 + n), $(4 + n), $(5 + n) * 57.29577951308232 }')
  if [ -z "$placed" ]; then
    echo "$log: left out: $(cat "$out/worlds/$log.err")" >&2
    rm -f "$out/worlds/$log.toml"
    continue
  fi
  echo "$log: start $placed; $(head -2 "$out/worlds/$log.toml" | tr '\n' ' ')"
  worlds+=("$out/worlds/$log.toml")
done
list=$(IFS=,; echo "${worlds[*]}")
"$lives" eval --worlds "$list" --trials 10 --heldout 0 --no-pictures --threads 2 --out "$out" "$@"
"$lives" eval --worlds "$list" --trials 10 --heldout 0 --no-pictures --threads 2 --known-map --out "$out-map" "$@"
