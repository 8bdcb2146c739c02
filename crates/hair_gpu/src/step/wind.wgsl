// --- Wind: hair_sim's `wind_at`, bit for bit in integer hashing ---

fn hash01(seed: u32) -> f32 {
    var x = seed;
    x ^= x >> 16u;
    x *= 0x7feb352du;
    x ^= x >> 15u;
    x *= 0x846ca68bu;
    x ^= x >> 16u;
    return f32(x >> 8u) / 16777216.0;
}

fn value_noise(seed: u32, t: f32) -> f32 {
    let i = floor(t);
    let f = t - i;
    let k = bitcast<u32>(i32(i));
    let a = hash01(seed ^ (k * 0x9e3779b9u));
    let b = hash01(seed ^ ((k + 1u) * 0x9e3779b9u));
    let s = f * f * (3.0 - 2.0 * f);
    return (a + (b - a) * s) * 2.0 - 1.0;
}

fn wind_at(strand: u32, time: f32) -> vec3<f32> {
    if step.wind.w == 0.0 {
        return vec3<f32>(0.0);
    }
    let t = time * step.gusts.y;
    let shared_gust = value_noise(0x5eedu, t);
    let own = value_noise(strand * 0x2545f491u, t * 1.7 + hash01(strand) * 16.0);
    let gust = 0.7 * shared_gust + 0.3 * own;
    return step.wind.xyz * step.wind.w * max(1.0 + step.gusts.x * gust, 0.0);
}
