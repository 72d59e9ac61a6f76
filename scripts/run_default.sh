#!/usr/bin/env bash
# README command one: installs what is missing and builds (scripts/setup.sh), then runs the
# default dam-break scene headless. Extra arguments go to the runner, e.g.
#   bash scripts/run_default.sh --duration 0.5 --threads 2
# Output: out/dam_break/ (summary.json, stats.csv, frames/NNNNNN.ply).
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

bash scripts/setup.sh
exec build/fluid_sim_run config/dam_break.yaml "$@"
