// hexbake player shaders (paper 000 §3.2; DESIGN.md "Shading").
//
// Originals: per-pixel Lambert in linear space,
//   albedo · (0.3 + 0.7 · max(0, n·L)), L = normalize(0.4, 1.0, 0.3),
// albedo = vertex sRGB8 colour → linear × instance tint × the model's albedo texture
// (group 2: Rgba8UnormSrgb, so texels are decoded to linear before the bilinear
// filter, no mipmaps — format::albedo on the CPU; a white texel for untextured
// models); the Rgba8UnormSrgb target encodes the linear result to sRGB8 (as
// worker::shade does on the CPU). The ground (issue 18) is drawn by the same vertex
// stage with fs_ground.
//
// Proxies: projective texturing from the proxy's captures (texcoord = M · world, / w,
// u right, v down, row 0 of the texture at v = 0). Each triangle carries the mask of
// the views that see it: none → lit vertex colour; one → that view; two or more → the
// two views whose direction to the triangle is closest to the viewer's (angle between
// eye_i → centroid and viewer → centroid), blended with weights inversely
// proportional to those angles. A texel outside [0,1]², behind the capture or with
// alpha < 0.5 (nothing captured there) falls back to the other view, then to lit.
// The choice of views depends on the triangle only, so the vertex stage makes it
// (once per vertex, not per pixel) and passes the two views' projective coordinates.
//
// Layered impostors (kind 4, paper 001): see impostor_layer below (alone, or a
// batch of up to PROXY_SLOTS impostors sharing one atlas, one draw call). Mesh
// proxies (SV/MV meshes, clusters) whose views share one encoding may likewise be
// drawn in batches sharing one atlas and one uniform (fs_proxy_atlas; up to
// PROXY_SLOTS views in all).

// AMBIENT, LIGHT, SRGB_* and MAX_VIEWS are not declared here: the player prepends
// format::shading::wgsl_constants() (player::gpu::shader_source), their one home.

struct Globals {
    clip_from_world: mat4x4<f32>,
    eye: vec4<f32>,
    // x: 1 = debug colouring by representation (player view's C key): albedo =
    // palette[representation], lit, no textures (overlay.rs, Representation).
    // y: 1 = coverage alpha. z, w: the dither range [z, w) of Bayer levels (0..64)
    // whose pixels the pipelines built with DITHER keep (issue 31 cross-fades).
    debug: vec4<u32>,
    palette: array<vec4<f32>, 8>,
};
@group(0) @binding(0) var<uniform> g: Globals;

// ---- cross-fades at cell borders (issue 31 item 2, player transition.rs) ----

// The pixel's level in the 8 × 8 Bayer matrix (0..64): the bit-reversed interleave
// of x ^ y and y (transition::bayer8 on the CPU).
fn bayer8(p: vec2<u32>) -> u32 {
    let y = p.y & 7u;
    let z = (p.x & 7u) ^ y;
    return ((z & 1u) << 5u) | ((y & 1u) << 4u) | ((z & 2u) << 2u) | ((y & 2u) << 1u)
        | ((z & 4u) >> 1u) | ((y & 4u) >> 2u);
}

// Whether a fragment at window position `clip` is outside this draw's dither
// range: another cell's representation owns the pixel. Only the DITHER pipelines
// call it (the renderer's module with the marker below replaced), so the others
// never discard and keep early depth testing.
fn dithered_out(clip: vec4<f32>) -> bool {
    let level = bayer8(vec2<u32>(clip.xy));
    return level < g.debug.z || level >= g.debug.w;
}

fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    let lo = c / SRGB_LINEAR_SLOPE;
    let hi = pow((c + vec3<f32>(SRGB_OFFSET)) / SRGB_SCALE, vec3<f32>(SRGB_GAMMA));
    return select(hi, lo, c <= vec3<f32>(SRGB_DECODE_THRESHOLD));
}

fn shade(albedo: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let l = max(dot(normalize(n), LIGHT), 0.0);
    return albedo * (AMBIENT + (1.0 - AMBIENT) * l);
}

// ---- originals ----

struct LitIn {
    @location(0) pos: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) albedo: vec4<f32>,
    @location(3) m0: vec4<f32>,
    @location(4) m1: vec4<f32>,
    @location(5) m2: vec4<f32>,
    @location(6) m3: vec4<f32>,
    @location(7) n0: vec4<f32>,
    @location(8) n1: vec4<f32>,
    @location(9) n2: vec4<f32>,
    @location(10) tint: vec4<f32>,
    @location(11) uv: vec2<f32>,
};

struct LitOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) albedo: vec3<f32>,
    @location(2) uv: vec2<f32>,
};

@group(2) @binding(0) var albedo_tex: texture_2d<f32>;
@group(2) @binding(1) var albedo_samp: sampler;

@vertex
fn vs_lit(v: LitIn) -> LitOut {
    let model = mat4x4<f32>(v.m0, v.m1, v.m2, v.m3);
    let nm = mat3x3<f32>(v.n0.xyz, v.n1.xyz, v.n2.xyz);
    var o: LitOut;
    o.clip = g.clip_from_world * (model * vec4<f32>(v.pos, 1.0));
    o.normal = nm * v.normal;
    o.albedo = srgb_to_linear(v.albedo.rgb) * v.tint.rgb;
    o.uv = v.uv;
    if g.debug.x != 0u {
        // The renderer put the representation's colour into the tint.
        o.albedo = v.tint.rgb;
    }
    return o;
}

@fragment
fn fs_lit(i: LitOut) -> @location(0) vec4<f32> {
    /*DITHER*/
    var albedo = i.albedo;
    if g.debug.x == 0u {
        albedo = albedo * textureSampleLevel(albedo_tex, albedo_samp, i.uv, 0.0).rgb;
    }
    return vec4<f32>(shade(albedo, i.normal), 1.0);
}

// The ground: lit vertex colour; background (alpha 0) to the coverage mask when
// g.debug.y is set (player compare's object pixels exclude it, as they do the sky).
@fragment
fn fs_ground(i: LitOut) -> @location(0) vec4<f32> {
    /*DITHER*/
    var a = 1.0;
    if g.debug.y != 0u {
        a = 0.0;
    }
    return vec4<f32>(shade(i.albedo, i.normal), a);
}

// ---- proxies ----

// View slots of a proxy's uniform (player vertex.rs PROXY_SLOTS): a lone proxy
// uses its first MAX_VIEWS, a batch of proxies sharing one atlas up to all of them
// (member views at consecutive slots from the member's base, vertex mask bits 16–23).
const PROXY_SLOTS: u32 = 64u;
// "No view" in ProxyOut.views.
const NO_VIEW: u32 = 255u;

struct Proxy {
    tex_from_world: array<mat4x4<f32>, PROXY_SLOTS>,
    view_eye: array<vec4<f32>, PROXY_SLOTS>,
    // x: number of views; y: bit i = view i's colours are premultiplied by coverage
    // (a batch has one encoding: bit 31 stands for the slots from 31 on);
    // z, w: the atlas's width and height in texels (0: one texture per view).
    counts: vec4<u32>,
    // With an atlas (t0 holds every view): view i's rectangle in it, as fractions.
    rects: array<vec4<f32>, PROXY_SLOTS>,
};
@group(1) @binding(0) var<uniform> p: Proxy;
@group(1) @binding(1) var samp: sampler;
@group(1) @binding(2) var t0: texture_2d<f32>;
@group(1) @binding(3) var t1: texture_2d<f32>;
@group(1) @binding(4) var t2: texture_2d<f32>;
@group(1) @binding(5) var t3: texture_2d<f32>;
@group(1) @binding(6) var t4: texture_2d<f32>;
@group(1) @binding(7) var t5: texture_2d<f32>;
@group(1) @binding(8) var t6: texture_2d<f32>;
@group(1) @binding(9) var t7: texture_2d<f32>;

struct ProxyIn {
    @location(0) pos: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) albedo: vec4<f32>,
    @location(3) tint: vec3<f32>,
    @location(4) mask: u32,
    @location(5) centroid: vec3<f32>,
    @location(6) kind: u32,
};

struct ProxyOut {
    @builtin(position) clip: vec4<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) albedo: vec3<f32>,
    // The two view slots drawn for this triangle (NO_VIEW = none): best0 | best1 << 8.
    @location(3) @interpolate(flat) views: u32,
    // Their blend weights when both have data (inversely proportional to the angles).
    @location(4) @interpolate(flat) weights: vec2<f32>,
    @location(5) @interpolate(flat) kind: u32,
    // Projective texture coordinates of the two views (tex_from_world · world, not yet
    // divided by w): affine in the world position, so interpolating them per vertex
    // is exact and saves two matrix products per pixel.
    @location(6) tc0: vec4<f32>,
    @location(7) tc1: vec4<f32>,
    // Layered impostors: the layer's depth codes (lo | hi << 8) and its impostor's
    // slot in a batch (bits 16–23; 0 alone).
    @location(8) @interpolate(flat) mask: u32,
    // Layered impostors in a batch: the impostor's rectangle of the atlas t0 in
    // texels (x, y, width, height), looked up once per vertex; 0 alone (no atlas).
    @location(9) @interpolate(flat) rect: vec4<u32>,
};

// What every proxy vertex passes on whatever its kind: position, lit-fallback
// inputs, mask and kind; no views yet.
fn proxy_common(v: ProxyIn) -> ProxyOut {
    var o: ProxyOut;
    o.clip = g.clip_from_world * vec4<f32>(v.pos, 1.0);
    o.normal = v.normal;
    o.albedo = srgb_to_linear(v.albedo.rgb) * v.tint;
    o.mask = v.mask;
    o.kind = v.kind;
    o.weights = vec2<f32>(0.5, 0.5);
    o.rect = vec4<u32>(0u);
    o.views = NO_VIEW | (NO_VIEW << 8u);
    o.tc0 = vec4<f32>(0.0);
    o.tc1 = vec4<f32>(0.0);
    if g.debug.x != 0u {
        o.albedo = g.palette[min(v.kind, 7u)].rgb;
    }
    return o;
}

// Every proxy kind: layered-impostor quads (kind 4) or mesh triangles.
@vertex
fn vs_proxy(v: ProxyIn) -> ProxyOut {
    var o = proxy_common(v);
    if v.kind == 4u {
        impostor_view(v, &o);
    } else {
        mesh_views(v, &o);
    }
    return o;
}

// Mesh proxies only (SV/MV meshes, clusters: never kind 4), for the pipelines that
// draw no impostor: a CPU rasterizer runs both sides of vs_proxy's branch under
// lane masks, and the impostor side cost ≈ 5 ms of a 512² city frame on llvmpipe.
@vertex
fn vs_proxy_mesh(v: ProxyIn) -> ProxyOut {
    var o = proxy_common(v);
    mesh_views(v, &o);
    return o;
}

// A layered-impostor vertex: its impostor's view, slot k of a batch (mask bits
// 16–23), 0 alone, and with an atlas its rectangle in texels.
fn impostor_view(v: ProxyIn, o: ptr<function, ProxyOut>) {
    let k = min((v.mask >> 16u) & 0xffu, PROXY_SLOTS - 1u);
    (*o).views = k | (NO_VIEW << 8u);
    (*o).tc0 = p.tex_from_world[k] * vec4<f32>(v.pos, 1.0);
    if p.counts.z != 0u {
        let atlas = vec2<f32>(f32(p.counts.z), f32(p.counts.w));
        let r = p.rects[k];
        (*o).rect = vec4<u32>(
            vec2<u32>(round(r.xy * atlas)),
            max(vec2<u32>(round(r.zw * atlas)), vec2<u32>(1u)),
        );
    }
}

// A mesh triangle's two views. The view choice depends only on the triangle (its
// mask and centroid, flat) and the eye, so it is made once per vertex here instead
// of once per pixel: of the views in the mask, the two whose direction to the
// centroid is closest to the viewer's. Mask bit k is view slot base + k, base being
// bits 16–23 (0 alone; a batch member's first slot).
fn mesh_views(v: ProxyIn, o: ptr<function, ProxyOut>) {
    let base = (v.mask >> 16u) & 0xffu;
    // The member's views: slots base … base + MAX_VIEWS − 1 that the proxy has, up
    // to the mask's highest bit (the loop runs as long as its longest lane, so a
    // triangle seen by views 0 and 1 only stops after two turns, not MAX_VIEWS).
    let slots = min(p.counts.x, PROXY_SLOTS);
    let highest = 32u - countLeadingZeros(v.mask & 0xffu);
    let n = min(min(slots - min(base, slots), MAX_VIEWS), highest);
    // Ranked by the cosine of the angle (the closest view has the largest), so the
    // arccosine is taken for the two chosen views only, for their weights.
    let to_poly = normalize(v.centroid - g.eye.xyz);
    var best0 = NO_VIEW;
    var best1 = NO_VIEW;
    var c0 = -2.0;
    var c1 = -2.0;
    for (var k = 0u; k < n; k = k + 1u) {
        if ((v.mask >> k) & 1u) == 0u {
            continue;
        }
        let slot = base + k;
        let c = dot(normalize(v.centroid - p.view_eye[slot].xyz), to_poly);
        if c > c0 {
            best1 = best0;
            c1 = c0;
            best0 = slot;
            c0 = c;
        } else if c > c1 {
            best1 = slot;
            c1 = c;
        }
    }
    let a0 = acos(clamp(c0, -1.0, 1.0));
    let a1 = acos(clamp(c1, -1.0, 1.0));
    (*o).views = best0 | (best1 << 8u);
    let s = a0 + a1;
    if best1 != NO_VIEW && s > 1e-6 {
        (*o).weights = vec2<f32>(a1 / s, a0 / s);
    }
    let world = vec4<f32>(v.pos, 1.0);
    if best0 != NO_VIEW {
        (*o).tc0 = p.tex_from_world[best0] * world;
    }
    if best1 != NO_VIEW {
        (*o).tc1 = p.tex_from_world[best1] * world;
    }
}

// The texture coordinates of projective coordinates tc (.xy) and whether they lie
// on the capture (.z = 1: in front of it and inside [0,1]²).
fn view_uv(tc: vec4<f32>) -> vec3<f32> {
    if tc.w <= 0.0 {
        return vec3<f32>(0.0);
    }
    let uv = tc.xy / tc.w;
    if any(uv < vec2<f32>(0.0)) || any(uv > vec2<f32>(1.0)) {
        return vec3<f32>(0.0);
    }
    return vec3<f32>(uv, 1.0);
}

// A texel c of view i as the blend takes it; alpha 0 = no data there.
fn captured(i: u32, c: vec4<f32>) -> vec4<f32> {
    if c.a < 0.5 {
        return vec4<f32>(0.0);
    }
    if ((p.counts.y >> min(i, 31u)) & 1u) != 0u {
        // Colours premultiplied by coverage (BC1 with punch-through alpha, format 4):
        // the uncovered taps are transparent black, so colour / alpha is the mean
        // of the covered taps.
        return vec4<f32>(c.rgb / c.a, 1.0);
    }
    return vec4<f32>(c.rgb, 1.0);
}

// Texture slots a mesh-proxy pipeline reads (pipeline-overridable, 1 to MAX_VIEWS:
// the proxy's views; GpuProxy::view_slots). A CPU rasterizer such as
// llvmpipe runs every branch of a fragment shader under lane masks, so a lookup
// "texture of view i" costs a sample of every slot it could be; with fewer slots
// the others fold away when the pipeline is compiled.
override VIEW_SLOTS: u32 = MAX_VIEWS;

// Slot k's texture sampled once, at view best0's coordinates when k is best0, else
// at best1's; handed to whichever of the two views k is.
fn take_slot(
    k: u32,
    t: texture_2d<f32>,
    best0: u32,
    best1: u32,
    uv0: vec2<f32>,
    uv1: vec2<f32>,
    s0: ptr<function, vec4<f32>>,
    s1: ptr<function, vec4<f32>>,
) {
    let c = textureSampleLevel(t, samp, select(uv1, uv0, k == best0), 0.0);
    if k == best0 {
        *s0 = c;
    }
    if k == best1 {
        *s1 = c;
    }
}

// Layered impostor (paper 001 §4; kind 4): a layer quad shows its impostor's texels
// whose alpha (a depth code, linear in the sRGB texture) lies in the layer's codes
// (mask = lo | hi << 8); the others are discarded (the alpha test), so the quad writes
// depth only where the layer has surface. The code is read from the nearest texel,
// the colour bilinearly (worker impostor.rs does the same on the CPU). Alone (no
// atlas: rect = 0) the impostor's texture is t0; in a batch (the player's upload,
// gpu/upload.rs) t0 is an atlas and the impostor's texture is its rectangle (slot
// k = mask bits 16–23; vs_proxy passes the rectangle in texels): the code texel is
// the nearest one mapped into it and the colour's bilinear taps are kept half a
// texel inside it, so the texels are those of its own clamped texture. Selects,
// not branches, and one sample: most layer fragments are discarded, and a CPU
// rasterizer runs both sides of a branch under lane masks.
fn impostor_layer(i: ProxyOut) -> vec4<f32> {
    let tc = i.tc0;
    if tc.w <= 0.0 {
        discard;
    }
    let uv = tc.xy / tc.w;
    if any(uv < vec2<f32>(0.0)) || any(uv >= vec2<f32>(1.0)) {
        discard;
    }
    let dims = textureDimensions(t0);
    let in_atlas = i.rect.z != 0u;
    let origin = select(vec2<u32>(0u), i.rect.xy, in_atlas);
    let size = select(dims, i.rect.zw, in_atlas);
    let texel = origin + min(vec2<u32>(uv * vec2<f32>(size)), size - vec2<u32>(1u));
    // Kept inside t0 (a batch drawn lit binds the 1 × 1 "nothing captured" texel).
    let code = u32(round(textureLoad(t0, min(texel, dims - vec2<u32>(1u)), 0).a * 255.0));
    let lo = i.mask & 0xffu;
    let hi = (i.mask >> 8u) & 0xffu;
    if code == 0u || code < lo || code > hi {
        discard;
    }
    if g.debug.x != 0u {
        return vec4<f32>(shade(i.albedo, -i.normal), 1.0);
    }
    let s = vec2<f32>(size);
    let at = (vec2<f32>(origin) + clamp(uv * s, vec2<f32>(0.5), s - vec2<f32>(0.5)))
        / vec2<f32>(dims);
    return vec4<f32>(textureSampleLevel(t0, samp, select(uv, at, in_atlas), 0.0).rgb, 1.0);
}

// Two fragment entry points (issue 17): fs_proxy_mesh for SV/MV meshes and clusters
// never discards, so the rasterizer may test depth before shading (llvmpipe turns
// early depth testing off for any shader that can discard, and then shades every
// proxy fragment, hidden or not); fs_proxy also draws layered impostors, whose
// alpha test needs discard. The renderer picks fs_proxy only for proxies with
// impostor layers (GpuProxy::layered); both shade a mesh fragment alike.
@fragment
fn fs_proxy(i: ProxyOut) -> @location(0) vec4<f32> {
    /*DITHER*/
    if i.kind == 4u {
        return impostor_layer(i);
    }
    return mesh_colour(i);
}

@fragment
fn fs_proxy_mesh(i: ProxyOut) -> @location(0) vec4<f32> {
    /*DITHER*/
    return mesh_colour(i);
}

// A mesh proxy's fragment: the two chosen views blended, else lit.
fn mesh_colour(i: ProxyOut) -> vec4<f32> {
    let lit = shade(i.albedo, i.normal);
    if g.debug.x != 0u {
        return vec4<f32>(lit, 1.0);
    }
    let best0 = i.views & 0xffu;
    let best1 = i.views >> 8u;
    if best0 == NO_VIEW {
        return vec4<f32>(lit, 1.0);
    }
    // The two views' texels: one sample per slot (not one per slot and view).
    let uv0 = view_uv(i.tc0);
    let uv1 = view_uv(i.tc1);
    var s0 = vec4<f32>(0.0);
    var s1 = vec4<f32>(0.0);
    take_slot(0u, t0, best0, best1, uv0.xy, uv1.xy, &s0, &s1);
    if VIEW_SLOTS > 1u {
        take_slot(1u, t1, best0, best1, uv0.xy, uv1.xy, &s0, &s1);
    }
    if VIEW_SLOTS > 2u {
        take_slot(2u, t2, best0, best1, uv0.xy, uv1.xy, &s0, &s1);
    }
    if VIEW_SLOTS > 3u {
        take_slot(3u, t3, best0, best1, uv0.xy, uv1.xy, &s0, &s1);
    }
    if VIEW_SLOTS > 4u {
        take_slot(4u, t4, best0, best1, uv0.xy, uv1.xy, &s0, &s1);
    }
    if VIEW_SLOTS > 5u {
        take_slot(5u, t5, best0, best1, uv0.xy, uv1.xy, &s0, &s1);
    }
    if VIEW_SLOTS > 6u {
        take_slot(6u, t6, best0, best1, uv0.xy, uv1.xy, &s0, &s1);
    }
    if VIEW_SLOTS > 7u {
        take_slot(7u, t7, best0, best1, uv0.xy, uv1.xy, &s0, &s1);
    }
    var c0 = vec4<f32>(0.0);
    if uv0.z != 0.0 {
        c0 = captured(best0, s0);
    }
    var c1 = vec4<f32>(0.0);
    if best1 != NO_VIEW && uv1.z != 0.0 {
        c1 = captured(best1, s1);
    }
    return blend(lit, c0, c1, i.weights);
}

// The two views' texels c0 and c1 (alpha 0: no data) blended with `weights` where
// both have data, else the one that has, else lit.
fn blend(lit: vec3<f32>, c0: vec4<f32>, c1: vec4<f32>, weights: vec2<f32>) -> vec4<f32> {
    var w0 = c0.a;
    var w1 = c1.a;
    if w0 > 0.0 && w1 > 0.0 {
        w0 = weights.x;
        w1 = weights.y;
    }
    if w0 + w1 <= 0.0 {
        return vec4<f32>(lit, 1.0);
    }
    return vec4<f32>((c0.rgb * w0 + c1.rgb * w1) / (w0 + w1), 1.0);
}

// View i's texel at its own coordinates uv ∈ [0,1]² from the atlas t0 (issue 30
// item 7): uv mapped into the view's rectangle and kept half a texel inside it, so
// the bilinear taps never reach a neighbouring view — the same taps as the view's
// own clamped texture gives.
fn atlas_texel(i: u32, uv: vec2<f32>) -> vec4<f32> {
    let r = p.rects[i];
    let half = vec2<f32>(0.5) / vec2<f32>(f32(p.counts.z), f32(p.counts.w));
    let a = clamp(r.xy + uv * r.zw, r.xy + half, r.xy + r.zw - half);
    return textureSampleLevel(t0, samp, a, 0.0);
}

// A mesh proxy whose views share one atlas texture (t0): a fragment samples only the
// two views it blends, where the per-view pipelines sample every slot (a CPU
// rasterizer runs each branch under lane masks). Never discards, like fs_proxy_mesh.
// Also a batch of single-view mesh proxies (the player's upload, gpu/upload.rs):
// slot k is member k's one view, and member k's triangles have mask bit k where a
// lone one's have bit 0, so vs_proxy_mesh chooses view k for them as it chose
// view 0.
@fragment
fn fs_proxy_atlas(i: ProxyOut) -> @location(0) vec4<f32> {
    /*DITHER*/
    let best0 = i.views & 0xffu;
    let best1 = i.views >> 8u;
    if g.debug.x != 0u || best0 == NO_VIEW {
        return vec4<f32>(shade(i.albedo, i.normal), 1.0);
    }
    let uv0 = view_uv(i.tc0);
    let uv1 = view_uv(i.tc1);
    var c0 = vec4<f32>(0.0);
    if uv0.z != 0.0 {
        c0 = captured(best0, atlas_texel(best0, uv0.xy));
    }
    var c1 = vec4<f32>(0.0);
    if best1 != NO_VIEW && uv1.z != 0.0 {
        c1 = captured(best1, atlas_texel(best1, uv1.xy));
    }
    // Lit only where neither view has data (blend's fallback), so textured
    // fragments skip the shading.
    if c0.a + c1.a <= 0.0 {
        return vec4<f32>(shade(i.albedo, i.normal), 1.0);
    }
    return blend(vec3<f32>(0.0), c0, c1, i.weights);
}
