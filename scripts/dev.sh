#!/usr/bin/env bash
# One entry point that does all set-up, then one job:
#   bash scripts/dev.sh render   render the default scene headless into screenshots/
#   bash scripts/dev.sh test     run the whole test suite
#   bash scripts/dev.sh shots    regenerate screenshots/ for every scene in scenes/
#   bash scripts/dev.sh setup    set up only
# Set-up (idempotent): Debian's Mesa EGL + llvmpipe (softpipe and zink over lavapipe for
# tests/test_drivers.py), OSMesa, Xvfb, the Noto CJK fonts
# and Chromium (the walkthrough's Hangul and its handout's tests) (apt-get when
# root, else the exact packages to install are printed), a virtual environment in
# .venv, and the project with its test tools installed into it.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
VENV="$ROOT/.venv"

APT_PACKAGES=(libegl1 libegl-mesa0 libgl1 libgl1-mesa-dri libglx-mesa0 libosmesa6 xvfb xauth xdotool
              fonts-noto-cjk fontconfig chromium mesa-vulkan-drivers libvulkan1 glslang-tools)
# mesa-vulkan-drivers (lavapipe) and libvulkan1: zink in tests/test_drivers.py, and pygfx
# (the optional peers extra, pbs bench --suites peers), which draws offscreen on Vulkan
PY_APT_PACKAGES=(python3 python3-venv python3-pip)

have_system_libs() {
    local ldconfig
    ldconfig=$(command -v ldconfig || echo /sbin/ldconfig)
    "$ldconfig" -p 2>/dev/null | grep -q 'libEGL_mesa.so.0' &&
    "$ldconfig" -p 2>/dev/null | grep -q 'libOSMesa.so' &&
    ls /usr/lib/*/dri/swrast_dri.so >/dev/null 2>&1 &&
    # the second Mesa driver's tests (tests/test_drivers.py, docs/drivers.md): zink over
    # lavapipe, Mesa's Vulkan rasteriser, through the Vulkan loader
    ls /usr/lib/*/dri/zink_dri.so >/dev/null 2>&1 &&
    "$ldconfig" -p 2>/dev/null | grep -q 'libvulkan.so.1' &&
    ls /usr/share/vulkan/icd.d/lvp_icd.*.json >/dev/null 2>&1 &&
    command -v Xvfb >/dev/null 2>&1 &&
    command -v xdotool >/dev/null 2>&1 &&
    # the walkthrough: Hangul labels and text (Noto Sans CJK), its handout's tests (Chromium)
    fc-match -f '%{file}' 'Noto Sans CJK KR' 2>/dev/null | grep -qi 'NotoSansCJK' &&
    command -v chromium >/dev/null 2>&1 &&
    # Khronos' reference GLSL compiler: every assembled program (tests/test_glsl_strict.py)
    command -v glslangValidator >/dev/null 2>&1
}

pick_python() {
    for py in python3.13 python3.12 python3.11 python3; do
        if command -v "$py" >/dev/null 2>&1 &&
           "$py" -c 'import sys, venv, ensurepip; sys.exit(sys.version_info < (3, 11))' 2>/dev/null; then
            echo "$py"; return 0
        fi
    done
    return 1
}

apt_install() {
    if [ "$(id -u)" -eq 0 ]; then
        echo "setup: installing with apt-get: $*"
        export DEBIAN_FRONTEND=noninteractive
        apt-get update -qq
        apt-get install -y -qq --no-install-recommends "$@" >/dev/null
    else
        echo "setup: missing system packages; as root run:" >&2
        echo "    apt-get install -y $*" >&2
        exit 1
    fi
}

setup() {
    have_system_libs || apt_install "${APT_PACKAGES[@]}"
    PY=$(pick_python) || { apt_install "${PY_APT_PACKAGES[@]}"; PY=$(pick_python); }
    if [ ! -x "$VENV/bin/python" ]; then
        echo "setup: creating $VENV with $PY"
        "$PY" -m venv "$VENV"
    fi
    # Reinstall only when the project's metadata changed.
    stamp="$VENV/.pbs-installed"
    want=$(sha256sum pyproject.toml | cut -d' ' -f1)
    if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
        echo "setup: installing the project and its dependencies into $VENV"
        "$VENV/bin/python" -m pip install -q --upgrade pip
        # distributed: pbs batch's Dask run, tested on a local cluster (tests/test_batch.py)
        "$VENV/bin/python" -m pip install -q -e ".[test,distributed]"
        # meshopt: EXT_meshopt_compression glTF files; it builds from source (a C++
        # compiler, about 25 s), so a machine where it does not build still renders and
        # tests everything else (such files are then refused naming the extra).
        "$VENV/bin/python" -m pip install -q -e ".[meshopt]" \
            || echo "setup: the meshopt extra did not build; meshopt-compressed glTF files will be refused"
        echo "$want" > "$stamp"
    fi
    # The bundled environments' prefiltered levels, made by this machine's GL into the
    # installation's seed of the prepared-texture cache (app/render/prepared_seed.py): a
    # first render starts with its environment made. Only where the seed is missing or
    # was made by other code (its VERSION file); a GL that cannot start just leaves it out.
    if ! "$VENV/bin/python" -m app.render.prepared_seed --if-stale "$VENV/share/pbs/prepared"; then
        echo "setup: no prefiltered environments seeded (first renders prefilter them)"
    fi
}

cmd=${1:-}
case "$cmd" in
    setup) setup ;;
    render)
        setup
        mkdir -p screenshots
        "$VENV/bin/pbs" render scenes/product_shot.toml -o screenshots/product_shot.png ;;
    shots)
        setup
        "$VENV/bin/python" -m app.screenshots ;;
    test)
        setup
        shift
        # The whole suite on two workers, each test file whole on one of them (its
        # module-level state and order kept): 9 min instead of 16 on two cores, since
        # most of a test's time is single-threaded Python, numpy and shader compiles.
        # Arguments replace these defaults (e.g. `test tests/test_fresnel.py -x`).
        if [ $# -eq 0 ]; then set -- -n 2 --dist loadfile tests/; fi
        "$VENV/bin/python" -m pytest "$@" ;;
    *)
        echo "usage: bash scripts/dev.sh render|test|shots|setup" >&2
        exit 2 ;;
esac
