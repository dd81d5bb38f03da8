// The two ways of handing out work (../PAPER §3, src/render): both end in `trace_pixel`.

// Chunk a workgroup took from the queue (shared so the whole workgroup walks it), the most loop
// iterations any of its invocations has run, and the most one tile has cost any of them.
var<workgroup> wg_chunk: u32;
var<workgroup> wg_iters: atomic<u32>;
var<workgroup> wg_tile_cost: atomic<u32>;

// Conventional mode: workgroups of one 32×2 tile take chunks of tiles through one atomic
// counter (`queue[0]`) from the host's boundary array `work_buf` (chunk c = tiles
// [work_buf[c], work_buf[c+1]), at most MAX_CHUNK_TILES), until the queue is empty, this
// workgroup has traced its budget of tiles, or one more chunk at the dearest tile cost seen
// could bring it near lavapipe's loop limit (its loops share one counter per invocation group
// for the whole dispatch). The host runs waves of workgroups until the counter passes the last
// chunk, and can cancel a frame between waves.
// launch.work = (chunks, tile budget per workgroup, tile columns, loop budget).
@compute @workgroup_size(TILE_W, TILE_H, 1)
fn render_queue(@builtin(local_invocation_id) lid: vec3u, @builtin(local_invocation_index) li: u32) {
    loop_iters = 0u;
    var taken = 0u;
    loop {
        // Every invocation's counts of the last chunk are in; one decides for all.
        workgroupBarrier();
        if li == 0u {
            let room = atomicLoad(&wg_iters) + MAX_CHUNK_TILES * atomicLoad(&wg_tile_cost) < launch.work.w;
            // (Not `select`: it would evaluate, and so take, a chunk either way.)
            wg_chunk = NO_HIT;
            if room && taken < launch.work.y {
                wg_chunk = atomicAdd(&queue[0], 1u);
            }
        }
        let c = workgroupUniformLoad(&wg_chunk);
        if c >= launch.work.x {
            break;
        }
        let t0 = work_buf[c];
        let t1 = work_buf[c + 1u];
        for (var t = t0; t < t1; t++) {
            let before = loop_iters;
            loop_iters += 1u;
            let x = (t % launch.work.z) * TILE_W + lid.x;
            let y = (t / launch.work.z) * TILE_H + lid.y;
            if x < params.eye_grid.x && y < params.eye_grid.y {
                trace_pixel(x, y);
            }
            atomicMax(&wg_tile_cost, loop_iters - before);
        }
        atomicMax(&wg_iters, loop_iters);
        taken += t1 - t0;
    }
}

// Frameless mode: one invocation per position of the slice [launch.work.x, + launch.work.y) of the
// pixel order. launch.work.z: ORDER_TABLE (work_buf holds the pixel of every position) or
// ORDER_DISSOLVE (work_buf holds the LFSR's jump matrices, launch.work.w its bits, launch.sample.z
// the state at the slice's first position; state v is pixel v - 1, values past the image skip).
@compute @workgroup_size(64, 1, 1)
fn render_slice(@builtin(global_invocation_id) gid: vec3u) {
    if gid.x >= launch.work.y {
        return;
    }
    loop_iters = 0u;
    var p: u32;
    if launch.work.z == ORDER_TABLE {
        p = work_buf[launch.work.x + gid.x];
    } else {
        p = dissolve_jump(launch.sample.z, gid.x, launch.work.w) - 1u;
        if p >= params.eye_grid.x * params.eye_grid.y {
            return;
        }
    }
    out_slot = gid.x;
    trace_pixel(p % params.eye_grid.x, p / params.eye_grid.x);
}

// The LFSR state `k` steps after `s`: the product of the matrices T^(2^j) for the set bits j
// of k, each applied as the XOR of the columns selected by the state's bits (GF(2)).
fn dissolve_jump(s0: u32, k: u32, bits: u32) -> u32 {
    var s = s0;
    for (var j = 0u; j < bits; j++) {
        loop_iters += 1u;
        if ((k >> j) & 1u) != 0u {
            var r = 0u;
            for (var i = 0u; i < bits; i++) {
                loop_iters += 1u;
                r ^= select(0u, work_buf[j * bits + i], ((s >> i) & 1u) != 0u);
            }
            s = r;
        }
    }
    return s;
}

// Conventional mode, once a frame is whole: its pixels (the output buffer) into the frame
// buffer, one invocation per pixel of the launch.work.x pixels from pixel launch.work.y on.
@compute @workgroup_size(64, 1, 1)
fn resolve_frame(@builtin(global_invocation_id) gid: vec3u) {
    let i = launch.work.y + gid.x;
    if i >= launch.work.x {
        return;
    }
    update_frame(i, out_buf[i].rgb);
}
