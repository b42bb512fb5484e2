#!/usr/bin/env bash
# The sweep examples that cannot run on this machine checked against their engines' schemas:
# the GitHub Actions workflow against SchemaStore's workflow schema (check-jsonschema's vendored
# copy), the Kubernetes Indexed Job against Kubernetes' OpenAPI schemas (kubernetes-validate).
# The Slurm example runs for real: docs/sweeps/slurm/run-local.sh.
#   bash docs/sweeps/validate.sh [VENV]      (default VENV: target/sweep-validate-venv)
set -euo pipefail
cd "$(dirname "$0")/../.."
venv=${1:-target/sweep-validate-venv}
[ -x "$venv/bin/pip" ] || python3 -m venv "$venv"
"$venv/bin/pip" install -q --disable-pip-version-check -r docs/sweeps/requirements-validate.txt
"$venv/bin/check-jsonschema" --builtin-schema vendor.github-workflows docs/sweeps/github-actions.yml
"$venv/bin/kubernetes-validate" --strict docs/sweeps/k8s-indexed-job.yaml
