#!/usr/bin/env bash
# Makes the secrets deploy/docker-compose.yml needs, in DIR (default deploy/secrets):
#   DIR/keys/                 CURVE keys (`ragdoll keygen`): broker, actor and learner pairs,
#                             and the public keys the broker accepts (keys/actors, keys/learners)
#   DIR/grafana_admin_password   a random password for Grafana's admin account
# Uses the `ragdoll` on PATH or in build/, else the image (RAGDOLL_IMAGE) through podman or
# docker. Keeps whatever already exists. Secret files get mode 0640 and group 10001 (the image's
# `ragdoll` user) so that the containers can read them; see deploy/README.md, "Keys".
#   deploy/make-secrets.sh [DIR]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
dir=${1:-$here/secrets}
mkdir -p "$dir/keys"
dir=$(cd "$dir" && pwd)

if [ ! -f "$dir/keys/broker.key_secret" ]; then
  if command -v ragdoll > /dev/null; then
    ragdoll keygen --keys "$dir/keys"
  elif [ -x "$here/../build/ragdoll" ]; then
    "$here/../build/ragdoll" keygen --keys "$dir/keys"
  else
    engine=$(command -v podman || command -v docker || true)
    [ -n "$engine" ] || { echo "make-secrets: no ragdoll binary, podman or docker found" >&2; exit 1; }
    "$engine" run --rm --user 0 -v "$dir/keys:/keys" "${RAGDOLL_IMAGE:-localhost/ragdoll:latest}" \
      keygen --keys /keys
  fi
else
  echo "make-secrets: $dir/keys already holds keys; keeping them"
fi
if [ ! -f "$dir/grafana_admin_password" ]; then
  (umask 077 && head -c 18 /dev/urandom | base64 | tr -d '\n/+=' > "$dir/grafana_admin_password")
  echo "make-secrets: Grafana's admin password is in $dir/grafana_admin_password"
fi
# Readable by the containers' user (uid and gid 10001) and by nobody else.
secrets=("$dir"/keys/*.key_secret "$dir/grafana_admin_password")
if [ "$(id -u)" = 0 ]; then
  chgrp 10001 "${secrets[@]}" && chmod 0640 "${secrets[@]}"
  chown 472 "$dir/grafana_admin_password"  # Grafana's image runs as uid 472
elif command -v podman > /dev/null; then
  podman unshare chgrp 10001 "${secrets[@]}" 2> /dev/null && chmod 0640 "${secrets[@]}" ||
    echo "make-secrets: give group 10001 read access to ${secrets[*]}" >&2
fi
echo "make-secrets: done; start the stack with RAGDOLL_SECRETS=$dir"
