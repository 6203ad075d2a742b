// SPDX-License-Identifier: Apache-2.0
// Virtual-pipe hydraulic erosion and thermal erosion. OpenCL C 1.2.
//
// Layout: every field is a float32 array with a zero halo: row pitch P (a multiple of 8), one pad
// row above and below the grid and 8 pad columns on the left; cell (x, y) is at (y + 1) * P + 8 + x.
// Pads are kept at zero by every kernel (stores are masked), so the outside of the grid reads as
// "no water, no flux, no sediment" without any index clamping.
//
// One work-item per row with an explicit float8 x-loop: PoCL runs one row per work-item fastest, and
// explicit vectors make every cell go through exactly the same instruction sequence, which is one
// ingredient of the bit-exact mirror symmetry (the other is that every sum over neighbours is a
// commutative pairing, ((L + R) + (T + B)), that a flip or a transpose maps onto itself).
//
// Determinism: no fast-math, FMA contraction off (a contracted a*b+c rounds differently from the
// uncontracted one, and mirror symmetry would then depend on which side the compiler fused).
// No NaN: fmax/fmin with the possibly-NaN operand first never propagate it, and every division has
// a denominator bounded away from zero.
//
// Build options: -DOPEN_BORDER (water and sediment drain over the grid edge), -DHAS_WEIGHT (a
// per-cell erosion weight in [0, 1]: the brush mask, 0 on hard constraints), -DDEPOSIT_LAYER (a
// softer deposit layer of thickness r on top of the rock: it dissolves at the full rate, rock at
// rock_factor times it, and it slides at its own talus angle).
#pragma OPENCL FP_CONTRACT OFF

#define PAD 8
#define TINY 1e-30f

// Work split: dimension 0 is the row, dimension 1 a chunk of XCHUNK cells of it (a multiple of 8,
// build option): the whole row per work-item on CPUs (PoCL's fastest form for stencils), a few
// vectors per work-item on GPUs, which need many more work-items than there are rows.
#ifdef XCHUNK
#define X_BEGIN ((int)get_global_id(1) * XCHUNK)
#define X_END min(W, X_BEGIN + XCHUNK)
#else
#define X_BEGIN 0
#define X_END W
#endif

typedef float8 V;
typedef int8 VI;

#define LD(p, i) vload8(0, (p) + (i))
#define ST(v, p, i) vstore8((v), 0, (p) + (i))
#define LANES ((VI)(0, 1, 2, 3, 4, 5, 6, 7))

// Outflow fluxes (m^3/s) of the four virtual pipes, updated in place. Rain (rain_dt metres) is added
// to the depth on the fly, identically here and in erosion_transport, so it needs no pass of its own.
//   f <- max(0, f + dt*A*g*dh/l) / (1 + dt*k_f): damping written semi-implicitly, which damps for every
//   dt instead of oscillating once the explicit coefficient exceeds 1.
// Outflows are scaled down only when their volume over dt exceeds the water present.
__kernel void erosion_flux(__global const float* restrict b, __global const float* restrict d,
                           __global float* restrict fl, __global float* restrict fr,
                           __global float* restrict ft, __global float* restrict fb, const int W, const int H,
                           const int P, const float rain_dt, const float kx, const float ky, const float damp,
                           const float area_over_dt) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t row = (size_t)(y + 1) * P + PAD;  // 64-bit: padded grids may pass 2^31 cells
  for (int x0 = X_BEGIN; x0 < X_END; x0 += 8) {
    const size_t i = row + x0;
    const VI xi = (VI)(x0) + LANES;
    const V bc = LD(b, i);
    const V dc = LD(d, i) + rain_dt;
    const V hc = bc + dc;
    V hl = LD(b, i - 1) + (LD(d, i - 1) + rain_dt);
    V hr = LD(b, i + 1) + (LD(d, i + 1) + rain_dt);
    V ht = LD(b, i - P) + (LD(d, i - P) + rain_dt);
    V hb = LD(b, i + P) + (LD(d, i + P) + rain_dt);
#ifdef OPEN_BORDER
    // Outside the grid: bare ground at the border cell's own bed level, so the border drains.
    hl = select(hl, bc, xi == 0);
    hr = select(hr, bc, xi == W - 1);
    if (y == 0) ht = bc;
    if (y == H - 1) hb = bc;
#endif
    V nl = fmax(LD(fl, i) + kx * (hc - hl), 0.0f) * damp;
    V nr = fmax(LD(fr, i) + kx * (hc - hr), 0.0f) * damp;
    V nt = fmax(LD(ft, i) + ky * (hc - ht), 0.0f) * damp;
    V nb = fmax(LD(fb, i) + ky * (hc - hb), 0.0f) * damp;
#ifndef OPEN_BORDER
    nl = select(nl, (V)(0.0f), xi == 0);
    nr = select(nr, (V)(0.0f), xi == W - 1);
    if (y == 0) nt = (V)(0.0f);
    if (y == H - 1) nb = (V)(0.0f);
#endif
    const V out = (nl + nr) + (nt + nb);
    const V avail = dc * area_over_dt;  // the outflow rate that empties the cell in one dt
    const V k = select((V)(1.0f), avail / fmax(out, TINY), out > avail);
    const VI valid = xi < W;
    ST(select((V)(0.0f), nl * k, valid), fl, i);
    ST(select((V)(0.0f), nr * k, valid), fr, i);
    ST(select((V)(0.0f), nt * k, valid), ft, i);
    ST(select((V)(0.0f), nb * k, valid), fb, i);
  }
}

// Sediment a pipe carries in dt: the donor's sediment times the fraction f*dt/(d0*a) of its water
// that the pipe takes, with r = (dt/a)/d0 computed once per donor. The receiver evaluates the same
// expressions on the same bits as the donor, so what leaves one cell is exactly what enters its
// neighbour. f*r <= 1 up to rounding because the outflows were scaled to the water present.
#define RATIO(d0) (dt_over_area / fmax((d0), TINY))
#define CARRIED(s, f, r) ((s) * fmin((f) * (r), 1.0f))

// Water and sediment transport, velocity, erosion/deposition and evaporation; writes the new bed,
// depth and sediment into the *_out arrays (the inputs are read by the neighbours).
//   s, d in metres (volume per cell area); fluxes in m^3/s; drain[2k], drain[2k+1] with
//   k = y * get_global_size(1) + get_global_id(1): water and sediment volume (m^3) that left through
//   the border in this work-item's part of row y (open border only), accumulated.
__kernel void erosion_transport(__global const float* restrict b, __global const float* restrict d,
                                __global const float* restrict s, __global const float* restrict fl,
                                __global const float* restrict fr, __global const float* restrict ft,
                                __global const float* restrict fb, __global const float* restrict w,
                                __global float* restrict b_out, __global float* restrict d_out,
                                __global float* restrict s_out, __global float* restrict drain, const int W,
                                const int H, const int P, const float rain_dt, const float dt_over_area,
                                const float inv_2lx, const float inv_2ly, const float inv_lx, const float inv_ly,
                                const float vcap, const float kc, const float sin_min, const float inv_dramp,
                                const float ks_dt, const float kd_dt, const float max_change,
                                const float dry_depth, const float evap_factor, const float cell_area,
                                __global const float* restrict r, __global float* restrict r_out,
                                const float rock_factor, __global float* restrict q_out, const float ws_dt,
                                const float conc_max, const float shear_depth,
                                __global const float* restrict b0) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t row = (size_t)(y + 1) * P + PAD;  // 64-bit: padded grids may pass 2^31 cells
#ifdef OPEN_BORDER
  V drained_w = (V)(0.0f), drained_s = (V)(0.0f);
#endif
  for (int x0 = X_BEGIN; x0 < X_END; x0 += 8) {
    const size_t i = row + x0;
    const VI xi = (VI)(x0) + LANES;
    const VI valid = xi < W;

    const V d0 = LD(d, i) + rain_dt;
    const V sc = LD(s, i);
    const V ol = LD(fl, i), orr = LD(fr, i), ot = LD(ft, i), ob = LD(fb, i);
    // Inflows: the neighbours' pipes pointing here (zero from the halo).
    const V il = LD(fr, i - 1), ir = LD(fl, i + 1), it = LD(fb, i - P), ib = LD(ft, i + P);

    const V qout = (ol + orr) + (ot + ob);
    const V qin = (il + ir) + (it + ib);
    const V d1 = fmax(d0 + (qin - qout) * dt_over_area, 0.0f);

    // Sediment moves with the water: each pipe carries its share of the donor's sediment.
    const V rc = RATIO(d0);
    const V sl = CARRIED(sc, ol, rc), sr = CARRIED(sc, orr, rc);
    const V st = CARRIED(sc, ot, rc), sb = CARRIED(sc, ob, rc);
    const V sil = CARRIED(LD(s, i - 1), il, RATIO(LD(d, i - 1) + rain_dt));
    const V sir = CARRIED(LD(s, i + 1), ir, RATIO(LD(d, i + 1) + rain_dt));
    const V sit = CARRIED(LD(s, i - P), it, RATIO(LD(d, i - P) + rain_dt));
    const V sib = CARRIED(LD(s, i + P), ib, RATIO(LD(d, i + P) + rain_dt));
    const V s1 = fmax((sc - ((sl + sr) + (st + sb))) + ((sil + sir) + (sit + sib)), 0.0f);

#ifdef OPEN_BORDER
    const V zero = (V)(0.0f);
    drained_w += select(zero, ol, (xi == 0) & valid) + select(zero, orr, (xi == W - 1) & valid);
    drained_s += select(zero, sl, (xi == 0) & valid) + select(zero, sr, (xi == W - 1) & valid);
    if (y == 0) drained_w += select(zero, ot, valid), drained_s += select(zero, st, valid);
    if (y == H - 1) drained_w += select(zero, ob, valid), drained_s += select(zero, sb, valid);
#endif

    // Velocity (m/s) from the mean flow through the cell, only where there is water to speak of,
    // capped at half a cell per dt.
    const V qx = 0.5f * ((il - ol) + (orr - ir));
    const V qy = 0.5f * ((it - ot) + (ob - ib));
    const V dm = 0.5f * (d0 + d1);
    const V inv_dm = 1.0f / fmax(dm, dry_depth);
    V u = (qx * inv_ly) * inv_dm;
    V v = (qy * inv_lx) * inv_dm;
    u = fmin(fmax(u, -vcap), vcap);
    v = fmin(fmax(v, -vcap), vcap);
    const V speed = select((V)(0.0f), sqrt(u * u + v * v), dm > dry_depth);

    // Local slope from central differences (one-sided at the border).
    const V bc = LD(b, i);
    V bl = LD(b, i - 1), br = LD(b, i + 1), bt = LD(b, i - P), bb = LD(b, i + P);
    bl = select(bl, bc, xi == 0);
    br = select(br, bc, xi == W - 1);
    if (y == 0) bt = bc;
    if (y == H - 1) bb = bc;
    const V gx = (br - bl) * inv_2lx, gy = (bb - bt) * inv_2ly;
    // The slope that drives the flow is the bed's fall along the velocity, not the steepest slope of
    // the cell: across a channel the steepest slope is the bank's, which would put the capacity's
    // maximum at the toes of the banks and leave the thalweg as a raised rib between two grooves.
    // gx*u + gy*v pairs up the same way under a flip or a transpose (mirror symmetry holds).
    // (Divided by the raw speed, at least 1e-6 m/s: the quotient is at most |grad b|.)
    const V fall = fmax(-((gx * u) + (gy * v)) / fmax(sqrt(u * u + v * v), 1e-6f), 0.0f);
    const V sin_slope = fall / sqrt(1.0f + fall * fall);

    // Transport capacity (m of sediment) and the exchange with the bed: delta > 0 dissolves.
    // ws_dt (settling velocity x dt, m) settles the excess at w_s/d in the recession phase (0 while it
    // rains; docs/erosion.md, "The valley ribbon: recession phase and a depth-bounded pick-up").
    // conc_max bounds only the pick-up (a load of conc_max x depth picks up no more); a load above the
    // capacity still settles at the slow rate, so valleys do not fill at once.
    // Excess shear: the bed shear stress rho*g*d*S must pass the critical tau_c before the flow
    // detaches anything, written as S - (tau_c/(rho*g))/d (shear_depth = tau_c/(rho*g), m): thin
    // sheet flow on hillslopes carries what it is given but cuts nothing, deep channel flow cuts.
    const V sin_eff = fmax(fmax(sin_slope, sin_min) - shear_depth / fmax(d1, dry_depth), 0.0f);
    const V cap = ((kc * sin_eff) * speed) * fmin(d1 * inv_dramp, 1.0f);
#ifdef CHANNEL_DIFFUSION
    // Unit discharge (m^2/s) for the channel diffusion of erosion_thermal (banks slumping into the
    // flow), times the flow's share of excess shear (sin_eff over the slope term, in [0, 1]): only
    // water that cuts its bed undermines its banks, so sheet flow on hillslopes leaves them alone.
    const V cutting = sin_eff / fmax(fmax(sin_slope, sin_min), TINY);
    ST(select((V)(0.0f), (speed * dm) * fmin(cutting, 1.0f), valid), q_out, i);
#endif
    const V pick = fmin(cap, conc_max * d1);
    const V kd = fmax(fmin(ws_dt / fmax(d1, dry_depth), 1.0f), kd_dt);
    V delta = select(select(kd * (cap - s1), 0.0f, cap > s1), ks_dt * (pick - s1), pick > s1);
    delta = select(delta, -s1, d1 <= dry_depth);  // a dry cell deposits all it carries
    delta = fmin(fmax(delta, -max_change), max_change);
#ifdef BANK_ROOM
    // Deposits build no rim: the bed may rise above its input height b0 only on low ground, by at
    // most the water depth there (sediment settles out of the water column), tapering to nothing at
    // a steepest slope of 0.1 (6 deg): valley floors and fans aggrade, banks and slopes refill their
    // cuts only. The load that may not settle stays suspended and travels on.
    {
      const V g2b = gx * gx + gy * gy;
      const V allow = d1 * fmax(1.0f - sqrt(g2b / (1.0f + g2b)) * 10.0f, 0.0f);
      delta = fmax(delta, -fmax((LD(b0, i) + allow) - bc, 0.0f));
    }
#endif
#ifdef HAS_WEIGHT
    delta = delta * LD(w, i);
#endif
#ifdef DEPOSIT_LAYER
    // Dissolving takes the deposit first; what is asked beyond it comes out of the harder rock at
    // rock_factor times the rate. Deposition adds to the deposit.
    const V rc0 = LD(r, i);
    const V asked = delta;
    const V from_deposit = fmin(fmax(asked, 0.0f), rc0);
    delta = select(asked, from_deposit + (asked - from_deposit) * rock_factor, asked > 0.0f);
    const V r1 = select(rc0 - asked, rc0 - from_deposit, asked > 0.0f);
    ST(select((V)(0.0f), fmax(r1, 0.0f), valid), r_out, i);
#endif
    // The sediment receives what the bed actually lost after rounding (bc - b1 is exact when the
    // change is small against the bed), not the nominal delta: a change below half an ulp of a
    // 1000 m bed would otherwise vanish from the bed but still appear in the sediment.
    const V b1 = bc - delta;
    const V s2 = fmax(s1 + (bc - b1), 0.0f);
    const V d2 = d1 * evap_factor;

    ST(select((V)(0.0f), b1, valid), b_out, i);
    ST(select((V)(0.0f), d2, valid), d_out, i);
    ST(select((V)(0.0f), s2, valid), s_out, i);
  }
#ifdef OPEN_BORDER
  const float dtw = dt_over_area * cell_area;  // = dt
  float sw = ((drained_w.s0 + drained_w.s1) + (drained_w.s2 + drained_w.s3)) +
             ((drained_w.s4 + drained_w.s5) + (drained_w.s6 + drained_w.s7));
  float ss = ((drained_s.s0 + drained_s.s1) + (drained_s.s2 + drained_s.s3)) +
             ((drained_s.s4 + drained_s.s5) + (drained_s.s6 + drained_s.s7));
  const int k = y * (int)get_global_size(1) + (int)get_global_id(1);
  drain[2 * k] += sw * dtw;
  drain[2 * k + 1] += ss * cell_area;
#endif
}

// Thermal exchange (m) from a higher cell to a lower one whose height difference is diff (> 0 when
// the sender is higher): the excess over the talus height t. With a deposit layer, the sender's
// deposit (thickness rs) also slides down to the deposit talus td, but never more than rs.
// A cell evaluates OUT for its lower neighbours and IN (= the neighbour's OUT towards it) for its
// higher ones; the neighbour evaluates the same expressions on the same bits with diff negated,
// so each pair's exchange is exactly antisymmetric.
// kd adds linear diffusion (hillslope creep): kd * diff for every downhill pair, talus or not.
// With water (BANK_ROOM), the talus and channel shares (rr, kq) fill a receiver no higher than its
// elevation before the erosion: each of its 8 pairs may bring at most 1/8 of the room left below it
// (room = max(0, b0 - b) / 8, computed from the receiver's bits by both cells of the pair). Banks
// slump into the channel they undercut; nothing of theirs builds up above the ground beside it.
// With CREEP_INTO_CUTS the creep kd runs only into a receiver with room (below its input height), at
// its plain rate: the input's hillslopes keep their heights (a raw DEM's one-cell pits and steps are
// not smoothed away) and creep heals the cuts. Without it, creep is the plain hillslope diffusion. (Capping its amount at the
// room too made the float32 rounding of the many small capped gathers create material: 5e-4 of
// the volume moved in 300 steps.)
#ifdef DEPOSIT_LAYER
#define TALUS(diff, t, td, rs) fmax(fmax((diff) - (t), 0.0f), fmin(fmax((diff) - (td), 0.0f), (rs)))
#else
#define TALUS(diff, t, td, rs) fmax((diff) - (t), 0.0f)
#endif
#ifdef CREEP_INTO_CUTS
#define CREEP(kd, diff, room) select(z, (kd) * fmax((diff), 0.0f), (room) > 0.0f)
#else
#define CREEP(kd, diff, room) ((kd) * fmax((diff), 0.0f))
#endif
#define XFER(diff, t, td, rs, kd, kq, rr, room) \
  (fmin((rr) * TALUS(diff, t, td, rs) + (kq) * fmax((diff), 0.0f), (room)) + CREEP(kd, diff, room))

// Thermal erosion: material above the talus slope moves to lower neighbours (4 at distance l, 4 at
// the diagonal), rho times the excess height per pair and sub-step, plus linear diffusion (kd times
// the height difference of every downhill pair, kd = D*dt/distance^2). Because the transfer depends only
// on the pair, the sender's and the receiver's sides compute the same number, so the "compute, then
// gather" of a normalised scheme collapses into one gather pass.
__kernel void erosion_thermal(__global const float* restrict b, __global const float* restrict w,
                              __global float* restrict b_out, const int W, const int H, const int P,
                              const float rho, const float tx, const float ty, const float tdiag,
                              __global const float* restrict r, __global float* restrict r_out,
                              const float dtx, const float dty, const float dtdiag, const float kdx,
                              const float kdy, const float kddiag, __global const float* restrict q,
                              const float cqx, const float cqy, const float cqdiag, const float kmx,
                              const float kmy, const float kmdiag, __global const float* restrict b0) {
  const int y = get_global_id(0);
  if (y >= H) return;
  const size_t row = (size_t)(y + 1) * P + PAD;  // 64-bit: padded grids may pass 2^31 cells
  const int up = y > 0, down = y < H - 1;
  for (int x0 = X_BEGIN; x0 < X_END; x0 += 8) {
    const size_t i = row + x0;
    const VI xi = (VI)(x0) + LANES;
    const VI valid = xi < W;
    const VI left = xi > 0, right = xi < W - 1;
    const VI vup = (VI)(-up), vdown = (VI)(-down);
    const V bc = LD(b, i);
    const V z = (V)(0.0f);
#ifdef DEPOSIT_LAYER
    const V rc = LD(r, i);
#define RN(o) LD(r, i + (o))
#else
    const V rc = z;
#define RN(o) z
#endif
#ifdef HAS_WEIGHT
    // A pair exchanges material only as much as its less movable cell allows (0 = fixed).
    const V wc = LD(w, i);
#define PW(o) fmin(wc, LD(w, i + (o)))
#else
#define PW(o) 1.0f
#endif
#ifdef CHANNEL_DIFFUSION
    // Channel (fluvial) diffusion: banks slump into the flowing water, and only into it. A pair's
    // diffusivity is D + K_q * q_r (the 1/2 of (q_r + q_r) / 2 is in cq) with q_r the unit discharge
    // of the pair's lower cell, the one that receives, capped at the monotone limit km. A bank beside
    // a stream loses material to it; a dry cell never gains from it, so no bank is raised. Both cells
    // of a pair evaluate the same expression on the same bits (the receiver's q, the pair's height
    // difference negated), so the exchange stays antisymmetric.
    const V qc = LD(q, i);
#define QN(o) LD(q, i + (o))
#define KQ(kd, cq, km, qr) fmin((cq) * ((qr) + (qr)), (km) - (kd))
#else
    const V qc = z;
#define QN(o) z
#define KQ(kd, cq, km, qr) z
#endif
#ifdef BANK_ROOM
    const V roomc = fmax(LD(b0, i) - bc, 0.0f) * 0.125f;
#define ROOMN(o) (fmax(LD(b0, i + (o)) - LD(b, i + (o)), 0.0f) * 0.125f)
    // A capped receiver gathers up to 8 transfers to exactly its room while each sender may lose less
    // than half an ulp of its bed, which rounding then drops: material would appear. Transfers below
    // about 2 ulps of the pair's beds (the same bits on both sides) are not made at all.
#define ULPS(o) ((fabs(LD(b, i + (o))) + fabs(bc)) * 1.2e-7f)
#define KEEP(x, o) select(z, (x), (x) >= ULPS(o))
#else
    const V roomc = (V)(1e30f);
#define ROOMN(o) roomc
#define KEEP(x, o) (x)
#endif
#ifdef BANK_THERMAL
    // Bank failure only: the talus exchange runs only into a cell where water cuts (q > 0: unit
    // discharge above the critical shear), so a stream's oversteepened banks slump into it while the
    // cliffs and scarps of the input, where no water concentrates, stand.
#define RHO(qr) select(z, (V)(rho), (qr) > 0.0f)
#else
#define RHO(qr) rho
#endif
    // in/out for the neighbour at offset o with talus heights t (rock) and td (deposit): `in` (the
    // neighbour is higher) has this cell as receiver, `out` the neighbour.
#define EXCHANGE(o, t, td, kd, cq, km, mask, in, out)                                            \
    {                                                                                            \
      const V diff = LD(b, i + (o)) - bc;                                                        \
      const V qn = QN(o);                                                                        \
      const V xin = XFER(diff, t, td, RN(o), kd, KQ(kd, cq, km, qc), RHO(qc), roomc);            \
      const V xout = XFER(-diff, t, td, rc, kd, KQ(kd, cq, km, qn), RHO(qn), ROOMN(o));          \
      in = select(z, KEEP(xin, o) * PW(o), mask);                                                \
      out = select(z, KEEP(xout, o) * PW(o), mask);                                              \
    }
    V il, ol, ir, orr, it, ot, ib, ob, itl, otl, itr, otr, ibl, obl, ibr, obr;
    EXCHANGE(-1, tx, dtx, kdx, cqx, kmx, left, il, ol)
    EXCHANGE(1, tx, dtx, kdx, cqx, kmx, right, ir, orr)
    EXCHANGE(-P, ty, dty, kdy, cqy, kmy, vup, it, ot)
    EXCHANGE(P, ty, dty, kdy, cqy, kmy, vdown, ib, ob)
    EXCHANGE(-P - 1, tdiag, dtdiag, kddiag, cqdiag, kmdiag, vup & left, itl, otl)
    EXCHANGE(-P + 1, tdiag, dtdiag, kddiag, cqdiag, kmdiag, vup & right, itr, otr)
    EXCHANGE(P - 1, tdiag, dtdiag, kddiag, cqdiag, kmdiag, vdown & left, ibl, obl)
    EXCHANGE(P + 1, tdiag, dtdiag, kddiag, cqdiag, kmdiag, vdown & right, ibr, obr)
    const V net = (((il - ol) + (ir - orr)) + ((it - ot) + (ib - ob))) +
                  (((itl - otl) + (ibr - obr)) + ((itr - otr) + (ibl - obl)));
    ST(select(z, bc + net, valid), b_out, i);
#ifdef DEPOSIT_LAYER
    // What slides becomes deposit on the receiver; the sender loses deposit first.
    const V in = ((il + ir) + (it + ib)) + ((itl + ibr) + (itr + ibl));
    const V out = ((ol + orr) + (ot + ob)) + ((otl + obr) + (otr + obl));
    ST(select(z, fmax(rc - out, 0.0f) + in, valid), r_out, i);
#endif
#undef RN
#undef PW
#undef KQ
#undef ROOMN
#undef KEEP
#ifdef ULPS
#undef ULPS
#endif
#undef QN
#undef RHO
#undef EXCHANGE
  }
}
