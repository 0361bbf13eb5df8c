// Shadow pass, fragment stage: writes nothing but the rasterised depth (with the
// slope-scaled offset the pass sets, app/render/shadows.py).
void main() {
}
