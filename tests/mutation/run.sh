#!/usr/bin/env bash
# Mutation check: tests/mutation/run.sh [--sample N] [--seed S] [ID...]; --help for the rest.
# See docs/testing.md, "Mutation testing".
exec python3 "$(dirname "$0")/mutate.py" "$@"
