#!/usr/bin/env bash
# Install hybridhyst (editable, with the test tools) into the current Python environment.
# Editable, so that the Hydra config tree conf/ stays next to the package the apps import.
# torch is pinned first so that an existing matching build (CPU or CUDA) is kept as it is.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
python -m pip install "torch==2.13.0"
python -m pip install -e ".[dev]"
