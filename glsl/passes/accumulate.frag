// Jittered accumulation's running mean (app/render/antialias.py): the mean of samples
// 0..k from the mean of 0..k-1 and sample k, weight 1 / (k + 1); alpha averaged with
// the colour.
uniform sampler2D u_hdr;    // sample k, linear HDR
uniform sampler2D u_mean;   // the mean of samples 0..k-1 (sample k itself for k = 0)
uniform float u_weight;     // 1 / (k + 1)

out vec4 frag_color;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 mean = texelFetch(u_mean, px, 0);
    frag_color = mean + (texelFetch(u_hdr, px, 0) - mean) * u_weight;
}
