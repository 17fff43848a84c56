# Fly with gcs: arm, take off, fly to a point 19 m away, land; each step waits until done.
# Arguments go to gcs (e.g. -i 1: the second vehicle; --url URL). Run: sh examples/gcs_fly.sh
.venv/bin/gcs "$@" arm &&
.venv/bin/gcs "$@" takeoff 5 &&
.venv/bin/gcs "$@" goto 47.3979 8.5457 5 &&
.venv/bin/gcs "$@" land
