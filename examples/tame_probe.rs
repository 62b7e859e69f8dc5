//! An experiment, not a kernel: how much faster could the single-layer RGB transmittance
//! of the peer's data (one layer, unit directions, 0 < b ≤ 2^40) run if the packets whose
//! intermediates all stay in f32's normal range skipped the mantissa/exponent
//! bookkeeping? `tame` does the general kernel's operations on plain f32 (no frexp, no
//! exponent sums, no ldexp) in the same staged blocks, and only counts the blocks whose
//! range checks fail: no fallback, so its time is an upper bound of the gain. It checks
//! the bits against `Scene::evaluate` and prints both max |T − T_f64| (the C peer's
//! measure). `EXP2=1` also folds −log2(e) into the extinction and takes T from
//! `exp2_nonpos` (one more rounding of τ in T, other bits).
//!
//! Since commit 9c0b1a7 the kernel's first stage takes this arithmetic per packet
//! (`depth_args_tame`, keeping e^(−u_min) split so that every packet of both data sets
//! qualifies): on the Zen 1 machine the probe and `Scene::evaluate` now run at the same
//! speed (1.00×, against 1.21× before). The probe stays as the measure of what the
//! kernel's remaining range handling costs.
//!
//! `cargo run --release --example tame_probe [typical|extreme]` (and the same with
//! `CARGO_TARGET_DIR=target/v4 RUSTFLAGS="-C target-cpu=x86-64-v4"`); README "Speed" and docs/speed-history.md.
use analytic_fog::math::{exp2_nonpos, exp_neg, exp_split, exprel_neg, Lane};
use analytic_fog::reference::peer::{scene_desc, PeerRays, BETA, FALLOFF};
use analytic_fog::{Outputs, Rays, Scene};
#[cfg(target_feature = "avx512f")]
type W = wide::f32x16;
#[cfg(not(target_feature = "avx512f"))]
type W = wide::f32x8;
const BLOCK: usize = 16;
const TWO_M64: f32 = 1.0 / TWO64;
const TWO64: f32 = 18_446_744_073_709_551_616.0;

#[inline(never)]
fn tame<const EXP2: bool>(
    oy: &[f32],
    dy: &[f32],
    t: &[f32],
    out: [&mut [f32]; 3],
    b: f32,
    h0: f32,
    s: [f32; 3],
) -> usize {
    let n = t.len();
    let (s_min, s_max) = (s[0].min(s[1]).min(s[2]), s[0].max(s[1]).max(s[2]));
    let nl = W::LANES;
    let [o0, o1, o2] = out;
    let z = W::splat(0.0);
    let mut dcs = [z; BLOCK];
    let mut nus = [z; BLOCK];
    let mut ts = [z; BLOCK];
    let mut gs = [z; BLOCK];
    let mut bad = 0usize;
    let mut i = 0;
    while i < n {
        let m = ((n - i) / nl).min(BLOCK);
        let w = m * nl;
        let mut okall = W::splat(0.0).eq(z);
        for (k, ((y, u), tt)) in oy[i..i + w]
            .chunks_exact(nl)
            .zip(dy[i..i + w].chunks_exact(nl))
            .zip(t[i..i + w].chunks_exact(nl))
            .enumerate()
        {
            let y = W::load(y);
            let u = W::load(u);
            let tt = W::load(tt);
            let a0s = W::splat(b) * (y * W::splat(TWO_M64) - W::splat(h0 * TWO_M64));
            let bu = W::splat(b) * u;
            let d = bu * tt;
            let dc = d.abs().max(W::splat(8.673_617e-19));
            let ds = d * W::splat(TWO_M64);
            let nu = (a0s + ds.min(z)) * W::splat(-TWO64);
            okall = okall
                & dc.lt(W::splat(256.0))
                & nu.abs().lt(W::splat(87.0))
                & (d.abs().ge(W::splat(1.2e-38)) | d.eq(z));
            dcs[k] = dc;
            nus[k] = nu;
            ts[k] = tt;
        }
        for k in 0..m {
            let phi = exprel_neg(dcs[k]);
            let (em, ek) = exp_split(nus[k]);
            let e = em.scale2(ek);
            let g = (ts[k] * phi) * e + z;
            // σ_c·G normal and finite for every channel.
            okall = okall & g.ge(W::splat(1.2e-38 / s_min)) & g.le(W::splat(f32::MAX / s_max));
            gs[k] = g;
        }
        for (ch, o) in [&mut *o0, &mut *o1, &mut *o2].into_iter().enumerate() {
            for (k, x) in o[i..i + w].chunks_exact_mut(nl).enumerate() {
                if EXP2 {
                    exp2_nonpos(W::splat(-s[ch] * std::f32::consts::LOG2_E) * gs[k]).store(x);
                } else {
                    exp_neg(W::splat(s[ch]) * gs[k]).store(x);
                }
            }
        }
        if W::any(!okall) {
            bad += 1;
        }
        i += w;
    }
    bad
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let extreme = args.get(1).map(String::as_str) == Some("extreme");
    let n = 65536;
    let peer = PeerRays::new(n, extreme);
    let (oy, dy, t) = (&peer.oy, &peer.dy, &peer.t);
    let z = vec![0.0f32; n];
    let scene = Scene::new(scene_desc()).unwrap();
    let rays = Rays::new(&z, oy, &z, &z, dy, &z, t)
        .unwrap()
        .with_unit_directions(true);
    let mut a: Vec<Vec<f32>> = (0..3).map(|_| vec![0.0f32; n]).collect();
    let mut bb: Vec<Vec<f32>> = (0..3).map(|_| vec![0.0f32; n]).collect();
    let reps = 300;
    let exp2 = std::env::var_os("EXP2").is_some();
    let (mut best_a, mut best_b) = (f64::INFINITY, f64::INFINITY);
    let mut bad = 0;
    for _ in 0..reps {
        let [x, y, w] = &mut a[..] else {
            unreachable!()
        };
        let t0 = std::time::Instant::now();
        scene
            .evaluate(
                &rays,
                Outputs {
                    tau: None,
                    transmittance: Some([x, y, w]),
                    inscattering: None,
                },
            )
            .unwrap();
        best_a = best_a.min(t0.elapsed().as_secs_f64());
        let [x, y, w] = &mut bb[..] else {
            unreachable!()
        };
        let t0 = std::time::Instant::now();
        bad = if exp2 {
            tame::<true>(oy, dy, t, [x, y, w], FALLOFF, 0.0, BETA)
        } else {
            tame::<false>(oy, dy, t, [x, y, w], FALLOFF, 0.0, BETA)
        };
        best_b = best_b.min(t0.elapsed().as_secs_f64());
    }
    let mut diff = 0;
    for c in 0..3 {
        for i in 0..n {
            if a[c][i].to_bits() != bb[c][i].to_bits() {
                diff += 1;
            }
        }
    }
    let blocks = n / (W::LANES * BLOCK);
    let (_, ea) = peer.max_trans_error([&a[0], &a[1], &a[2]]);
    let (_, eb) = peer.max_trans_error([&bb[0], &bb[1], &bb[2]]);
    println!("max|dT| RGB: general {ea:.3e}, probe {eb:.3e}");
    println!(
        "{}: general {:.3} ns/ray, tame {:.3} ns/ray ({:.2}x); bit diffs {diff}; untame blocks {bad}/{blocks}",
        if extreme { "extreme" } else { "typical" },
        best_a / n as f64 * 1e9,
        best_b / n as f64 * 1e9,
        best_a / best_b
    );
}
