# Sourced by .ci/run and .ci/demo (after `missing=()` and PY): what building the package needs — a C compiler,
# Python's headers (cffi compiles the C core against Python.h) and venv — added to `missing`, and
# install_missing, which apt-gets whatever `missing` lists.
command -v cc >/dev/null || missing+=(gcc libc6-dev)
"$PY" -c 'import os, sysconfig; raise SystemExit(not os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")))' \
    || missing+=(python3-dev)
"$PY" -c 'import ensurepip' 2>/dev/null || missing+=(python3-venv)

install_missing() {
    if ((${#missing[@]})); then
        local sudo
        sudo=$([ "$(id -u)" -eq 0 ] || echo sudo)
        $sudo apt-get update -qq && $sudo apt-get install -y -qq "${missing[@]}"
    fi
}
