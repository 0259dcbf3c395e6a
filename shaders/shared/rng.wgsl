// Counter-based random numbers, bit-identical to src/rng.rs: a value is a hash of its
// coordinates (seed, view, scale, pass, iteration, pixel), never of the schedule.

fn pcg_hash(input: u32) -> u32 {
    let state = input * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn hash_step(h: u32, c: u32) -> u32 {
    return pcg_hash(h ^ pcg_hash(c));
}

// hash_coords of 7 coordinates (the fold of src/rng.rs).
fn hash7(a: u32, b: u32, c: u32, d: u32, e: u32, f: u32, g: u32) -> u32 {
    var h = 0x9e3779b9u;
    h = hash_step(h, a);
    h = hash_step(h, b);
    h = hash_step(h, c);
    h = hash_step(h, d);
    h = hash_step(h, e);
    h = hash_step(h, f);
    h = hash_step(h, g);
    return h;
}

fn uniform01(key: u32) -> f32 {
    return f32(pcg_hash(key) >> 8u) * (1.0 / 16777216.0);
}

struct Stream {
    key: u32,
    counter: u32,
}

fn stream_next(s: ptr<function, Stream>) -> f32 {
    let v = uniform01((*s).key ^ pcg_hash((*s).counter));
    (*s).counter = (*s).counter + 1u;
    return v;
}
