"""ldbench/core/conventions.py and its GLSL twin ldbench/methods/glsl/common/conventions.glsl agree on random inputs (a compute
shader on the test GPU), and the epsilons are Mitsuba's."""
import numpy as np

from ldbench.core import conventions as conv

N = 4096
SHADER = """
#include "common/conventions.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer In { vec4 fin[]; };     // 8 per item
layout(std430, binding = 1) readonly buffer InU { uvec4 uin[]; };   // 1 per item
layout(std430, binding = 2) writeonly buffer Out { vec4 fout[]; };  // 9 per item
layout(std430, binding = 3) writeonly buffer OutU { uvec4 uout[]; };
uniform uint n_items;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= n_items) return;
    vec4 a = fin[8u * i], b = fin[8u * i + 1u], c = fin[8u * i + 2u], t03 = fin[8u * i + 3u];
    vec4 e = fin[8u * i + 4u], ctr = fin[8u * i + 5u], e1 = fin[8u * i + 6u], e2 = fin[8u * i + 7u];
    uvec4 k = uin[i];
    float u0 = a.w, u1 = b.w, cap = e.z;
    vec3 t, bt;
    tangent_frame(c.xyz, t, bt);
    fout[9u * i] = vec4(spawn_origin(a.xyz, c.xyz, CONV_RAY_EPSILON), ray_offset_scale(a.xyz, CONV_RAY_EPSILON));
    fout[9u * i + 1u] = vec4(t, 0.0);
    fout[9u * i + 2u] = vec4(bt, 0.0);
    fout[9u * i + 3u] = vec4(cosine_direction(c.xyz, u0, u1), 0.0);
    fout[9u * i + 4u] = vec4(phong_direction(c.xyz, c.w, u0, u1), 0.0);
    fout[9u * i + 5u] = vec4(sphere_point(ctr.xyz, ctr.w, u0, u1), 0.0);
    uint st = sample_stream(k.z, k.y, k.w);
    uint st0 = st;
    float p0 = pcg_uniform(st), p1 = pcg_uniform(st);
    float am = 0.0, ax = 0.0;
    float ts[6] = float[6](t03.x, t03.y, t03.z, t03.w, e.x, e.y);
    for (int j = 0; j < 6; ++j) { am = range_accumulate(am, ts[j], cap, 0); ax = range_accumulate(ax, ts[j], cap, 1); }
    fout[9u * i + 6u] = vec4(hash01(k.x, k.y), p0, p1, range_finish(am, 0));
    fout[9u * i + 7u] = vec4(range_finish(ax, 1), 0.0, 0.0, 0.0);
    fout[9u * i + 8u] = vec4(crease_point(a.xyz, e1.xyz, e2.xyz, vec2(e1.w, e2.w), CONV_RAY_EPSILON), 0.0);
    uout[i] = uvec4(lowbias32(k.x), st0, pcg_hash(k.x), 0u);
}
"""


def _inputs(rng):
    x = rng.uniform(-1, 1, (N, 3)) * 10.0 ** rng.uniform(-2, 2, (N, 1))
    toward = rng.normal(size=(N, 3))
    n = rng.normal(size=(N, 3))
    n[:8] = [[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, 1, 0], [0, 0, 1e-9], [0.6, 0, -0.8], [0, -1, 0], [-1, 0, 0]]
    toward, n = (v / np.linalg.norm(v, axis=1, keepdims=True) for v in (toward, n))
    u = rng.random((N, 2))
    exponent = 10.0 ** rng.uniform(0, 3, N)
    cap = rng.uniform(0.1, 5.0, N)
    t = rng.uniform(-1, 6, (N, 6))
    t[rng.random((N, 6)) < 0.15] = np.inf
    t[rng.random((N, 6)) < 0.05] = np.nan
    t[:, 0] = np.where(rng.random(N) < 0.1, cap, t[:, 0])  # exactly the cap
    centre = rng.uniform(-20, 20, (N, 3))
    radius = rng.uniform(0, 2, N)
    ints = rng.integers(0, 1 << 32, (N, 4), dtype=np.uint64).astype(np.uint32)
    # triangles (p0, p0 + e1, p0 + e2) around x: sizes from 1e-4 (smaller than the crease band) to 10,
    # x on an edge, near one (within a few ε), near a vertex, or inside
    size = 10.0 ** rng.uniform(-4, 1, (N, 1))
    e1, e2 = rng.normal(size=(N, 3)) * size, rng.normal(size=(N, 3)) * size
    uv = rng.dirichlet([1, 1, 1], N)[:, 1:]
    near = rng.random(N)
    uv[near < 0.2, 0] = 0.0                                              # on the edge p0-p2
    uv[(near >= 0.2) & (near < 0.4), 1] *= 1e-5                          # near the edge p0-p1
    uv[(near >= 0.4) & (near < 0.5)] = rng.random((np.count_nonzero((near >= 0.4) & (near < 0.5)), 2)) * 1e-6
    side = (near >= 0.5) & (near < 0.6)                                  # near the edge p1-p2
    uv[side] *= (1.0 - 1e-6) / uv[side].sum(1, keepdims=True)
    tri = (e1, e2, uv)
    return x, toward, n, u, exponent, cap, t, centre, radius, ints, tri


def test_python_and_glsl_conventions_agree(gpu, tmp_path):
    x, toward, n, u, exponent, cap, t, centre, radius, ints, (e1, e2, uv) = _inputs(np.random.default_rng(7))
    # float32 inputs on both sides (the shader sees float32)
    f32 = lambda a: np.asarray(a, np.float32).astype(np.float64)  # noqa: E731
    x, toward, n, u, exponent, cap, t, centre, radius, e1, e2, uv = map(
        f32, (x, toward, n, u, exponent, cap, t, centre, radius, e1, e2, uv))
    fin = np.zeros((N, 8, 4), np.float32)
    fin[:, 0, :3], fin[:, 0, 3] = x, u[:, 0]
    fin[:, 1, :3], fin[:, 1, 3] = toward, u[:, 1]
    fin[:, 2, :3], fin[:, 2, 3] = n, exponent
    fin[:, 3, :] = t[:, :4]
    fin[:, 4, 0:2], fin[:, 4, 2] = t[:, 4:], cap
    fin[:, 5, :3], fin[:, 5, 3] = centre, radius
    fin[:, 6, :3], fin[:, 6, 3] = e1, uv[:, 0]
    fin[:, 7, :3], fin[:, 7, 3] = e2, uv[:, 1]
    (tmp_path / "conv_test.glsl").write_text(SHADER)
    cs = gpu.compute(tmp_path / "conv_test.glsl")
    bufs = [gpu.ctx.buffer(fin.tobytes()), gpu.ctx.buffer(ints.tobytes()),
            gpu.ctx.buffer(reserve=N * 9 * 16), gpu.ctx.buffer(reserve=N * 16)]
    for i, b in enumerate(bufs):
        b.bind_to_storage_buffer(i)
    cs["n_items"] = N
    cs.run((N + 63) // 64)
    out = np.frombuffer(gpu.read(bufs[2]), np.float32).reshape(N, 9, 4).astype(np.float64)
    uout = np.frombuffer(gpu.read(bufs[3]), np.uint32).reshape(N, 4)
    for b in bufs:
        b.release()

    unit = lambda v: v / np.linalg.norm(v, axis=1, keepdims=True)  # noqa: E731
    eps = conv.offset_scale(x)
    np.testing.assert_allclose(out[:, 0, 3], eps, rtol=1e-6)
    o = conv.spawn_origin(x, n)
    # the offset o - x itself must agree (x alone would hide it): to float32 rounding of x
    err = np.abs((out[:, 0, :3] - x) - (o - x)).max(1)
    assert np.all(err <= 1.2e-7 * np.abs(x).max(1) + 1e-4 * eps)
    cp = conv.crease_point(x, e1, e2, uv)
    moved = np.linalg.norm(cp - x, axis=1) > 0
    assert 0.3 < moved.mean() < 0.8  # both branches are exercised
    err = np.abs((out[:, 8, :3] - x) - (cp - x)).max(1)
    # float32 rounding of x, and of the barycentric 1 - u - v (times the triangle's size)
    size = np.linalg.norm(e1, axis=1) + np.linalg.norm(e2, axis=1)
    assert np.all(err <= 2.4e-7 * np.abs(x).max(1) + 1e-7 * size + 1e-3 * np.linalg.norm(cp - x, axis=1))
    tt, bb = conv.tangent_frame(n)
    np.testing.assert_allclose(out[:, 1, :3], tt, atol=2e-5)
    np.testing.assert_allclose(out[:, 2, :3], bb, atol=2e-5)
    np.testing.assert_allclose(out[:, 3, :3], unit(conv.cosine_direction(n, u)), atol=5e-5)
    np.testing.assert_allclose(out[:, 4, :3], unit(conv.phong_direction(n, exponent, u)), atol=1e-4)
    np.testing.assert_allclose(out[:, 5, :3], conv.sphere_point(centre, radius, u), atol=1e-4)
    np.testing.assert_array_equal(uout[:, 0], conv.hash32(ints[:, 0]))
    np.testing.assert_array_equal(out[:, 6, 0], conv.hash01(ints[:, 0], ints[:, 1]))
    st = conv.sample_stream(ints[:, 2], ints[:, 1], ints[:, 3])
    np.testing.assert_array_equal(uout[:, 1], st)
    np.testing.assert_array_equal(uout[:, 2], conv.pcg_hash(ints[:, 0]))
    np.testing.assert_array_equal(out[:, 6, 1:3], conv.pcg_uniforms(st, 2))
    for mode, got in (("mean", out[:, 6, 3]), ("max", out[:, 7, 0])):
        ref = np.concatenate([conv.reduce_range(t[i], float(cap[i]), mode) for i in range(N)])
        np.testing.assert_allclose(got, ref, rtol=1e-6)

    from ldbench.references.rays import epsilons
    assert epsilons() == (np.float32(conv.RAY_EPSILON), np.float32(conv.SHADOW_EPSILON))

