#!/usr/bin/env bash
# Installs every Debian package ragdoll needs to build, test and run, and the ONNX export test's
# Node.js packages. Idempotent: what is already installed is left alone, so running it again is
# cheap.
set -euo pipefail

packages=(
  # toolchain
  build-essential cmake ninja-build pkg-config git clang-format
  # simulation and learning
  libmujoco-dev libmujoco-samples libtorch-dev libgloo-dev
  # MuJoCo's CMake package looks for OpenGL even when nothing is rendered
  libgl-dev libopengl-dev
  # libtorch links libblas.so.3; OpenBLAS registers itself as that alternative and is 5-10x
  # faster than the reference BLAS for the policy's matrix products (docs/environment measured).
  libopenblas0-openmp
  # transport, wire format, metrics; checkpoint checksums (SHA-256)
  libzmq3-dev cppzmq-dev libprotobuf-dev protobuf-compiler prometheus-cpp-dev libsodium-dev
  libmicrohttpd-dev
  # config, command line, JSON
  libyaml-cpp-dev libcli11-dev nlohmann-json3-dev
  # tests and benchmarks; fuzzing with clang's libFuzzer, ASan and UBSan (tests/fuzz/)
  libgtest-dev libgmock-dev libbenchmark-dev clang libclang-rt-14-dev
  # motion import: FBX, glTF/GLB and COLLADA through Assimp; its command-line tool writes the
  # test files in other tools' formats
  libassimp-dev assimp-utils
  # the import tests read FBX, GLB and COLLADA files that Blender writes, as users' files are
  blender
  # policy export: the ONNX graph built with ONNX's own protobuf classes and checker
  libonnx-dev python3-onnx
  # rendering videos headless: GLFW + Mesa under Xvfb, frames encoded by ffmpeg; the play test
  # presses keys in `ragdoll play`'s window with xdotool
  libglfw3-dev libgl1-mesa-dri xvfb xauth ffmpeg xdotool
  # integration tests: a real Prometheus server, queried over HTTP from the shell
  prometheus curl jq
  # test scripts decode PNG screenshots with a few lines of Python (standard library only)
  python3
  # `ragdoll report --png`: rsvg-convert rasterises the curves' SVG
  librsvg2-bin
  # the report's integration test opens the page in headless Chromium
  chromium
  # the container end-to-end test: Podman runs deploy/docker-compose.yml (no Docker engine
  # needed), on a Debian base image built locally with debootstrap
  podman podman-compose runc netavark aardvark-dns iptables debootstrap
)

# ONNX Runtime's Node.js binding checks exported policies (tests/onnx/); Debian's Node.js and npm
# unless the machine already has them.
if ! command -v npm > /dev/null; then packages+=(nodejs npm); fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages already installed"
else
  sudo=""
  if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
  echo "setup: installing ${#missing[@]} packages: ${missing[*]}"
  $sudo apt-get update -q
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# The ONNX export test's Node.js dependencies (ONNX Runtime's binding), exactly as
# tests/onnx/package-lock.json pins them, into tests/onnx/node_modules. --ignore-scripts: the
# package carries its Linux x64 library; its install script only fetches optional GPU extras.
# Skipped when node_modules was installed from the same lock file.
onnx_test="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/tests/onnx"
stamp="$onnx_test/node_modules/.installed-from-package-lock.json"
if cmp -s "$onnx_test/package-lock.json" "$stamp"; then
  echo "setup: tests/onnx/node_modules up to date"
else
  echo "setup: installing tests/onnx's Node.js packages (npm ci)"
  (cd "$onnx_test" && npm ci --ignore-scripts --no-audit --no-fund)
  cp "$onnx_test/package-lock.json" "$stamp"
fi
