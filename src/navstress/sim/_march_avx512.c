/* The lidar's terrain cell walk for one channel, eight rays at a time (AVX-512).
 *
 * The native twin of navstress.sim._raycast.walk_cells: it computes exactly what that numba walk
 * computes, operation for operation in IEEE double precision (no fused multiply-adds: compiled
 * with -ffp-contract=off), so both give bit-identical ranges; tests/unit/sim/test_native.py
 * checks that on random scenes, and fails instead of skipping with NAVSTRESS_REQUIRE_NATIVE=1
 * (.ci/run sets it where the CPU has AVX-512F/DQ/VL and a C compiler exists). Change the two
 * together. Built at first use by navstress.sim.native (a C compiler is needed; without one, or
 * on a CPU without AVX-512F/DQ/VL, navstress uses the numba walk) and called by address from
 * _raycast.terrain_kernel.
 *
 * Queue (structure of arrays, rows of Q with stride qs; ray q = column of the channel):
 *   Q[0] t (march start), Q[1] tmx, Q[2] tmy (where the ray leaves its start cell in x / y),
 *   Q[3] |1/dx|, Q[4] |1/dy| (t per cell), Q[5] dx, Q[6] dy (cell units per metre), Q[7] dz,
 *   Q[8] tend (end of the walk); I[0] cx, I[1] cy (start cell), I[2] sx, I[3] sy (cell steps, +-1).
 * Result: R[q] = hit t or +inf.
 * Terrain: h (rows of W = ncx + 1 float32 heights); a cell's max height is the max of its corners.
 */
#include <stdint.h>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define NV_SIMD 1
#endif

int nv_march_ok(void) {
#ifdef NV_SIMD
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl");
#else
    return 0;
#endif
}

#ifdef NV_SIMD
#define NV_TARGET __attribute__((target("avx512f,avx512dq,avx512vl")))
#define GLO(u, v) _mm512_add_pd(_mm512_add_pd(h00, _mm512_mul_pd(u, A)), _mm512_mul_pd(v, Bl))
#define GUP(u, v) _mm512_add_pd(_mm512_add_pd(h00, _mm512_mul_pd(v, Bu)), _mm512_mul_pd(u, Au))

NV_TARGET void nv_march_channel(const float *h, int64_t W, int64_t ncx, int64_t ncy, double oz,
                                double oxc, double oyc, int64_t nq, const double *Q, const int64_t *I, int64_t qs,
                                double *R) {
    const double *Q_t = Q, *Q_tmx = Q + qs, *Q_tmy = Q + 2 * qs, *Q_tdx = Q + 3 * qs, *Q_tdy = Q + 4 * qs;
    const double *Q_dx = Q + 5 * qs, *Q_dy = Q + 6 * qs, *Q_dz = Q + 7 * qs, *Q_tend = Q + 8 * qs;
    const int64_t *Q_cx = I, *Q_cy = I + qs, *Q_sx = I + 2 * qs, *Q_sy = I + 3 * qs;
    double *R_th = R;
    for (int64_t q = 0; q < nq; q++) R_th[q] = 1.0 / 0.0;  /* a miss unless a hit is written */
    const __m512d voz = _mm512_set1_pd(oz), vox = _mm512_set1_pd(oxc), voy = _mm512_set1_pd(oyc);
    const __m512d zero = _mm512_setzero_pd(), one = _mm512_set1_pd(1.0), vinf = _mm512_set1_pd(1.0 / 0.0);
    const __m512i vncx = _mm512_set1_epi64(ncx), vncy = _mm512_set1_epi64(ncy), vW = _mm512_set1_epi64(W);
    const __m512i izero = _mm512_setzero_si512(), lane = _mm512_set_epi64(7, 6, 5, 4, 3, 2, 1, 0);
    __m512d t = zero, tmx = zero, tmy = zero, tdx = zero, tdy = zero, dx = zero, dy = zero, dz = zero;
    __m512d tend = zero;
    __m512i cx = izero, cy = izero, sx = izero, sy = izero, qid = izero;
    __mmask8 act = 0;
    int64_t next = 0;
    for (;;) {
        __mmask8 fr = (__mmask8)~act;
        if (fr && next < nq) {  /* refill the free lanes from the queue, in queue order */
            int64_t avail = nq - next;
            int nf = __builtin_popcount((unsigned)fr);
            if (avail < nf) {
                __mmask8 m = 0;
                int c = 0;
                for (int j = 0; j < 8 && c < avail; j++)
                    if (fr >> j & 1) { m |= (__mmask8)(1u << j); c++; }
                fr = m;
                nf = (int)avail;
            }
            t = _mm512_mask_expandloadu_pd(t, fr, Q_t + next);
            tmx = _mm512_mask_expandloadu_pd(tmx, fr, Q_tmx + next);
            tmy = _mm512_mask_expandloadu_pd(tmy, fr, Q_tmy + next);
            tdx = _mm512_mask_expandloadu_pd(tdx, fr, Q_tdx + next);
            tdy = _mm512_mask_expandloadu_pd(tdy, fr, Q_tdy + next);
            dx = _mm512_mask_expandloadu_pd(dx, fr, Q_dx + next);
            dy = _mm512_mask_expandloadu_pd(dy, fr, Q_dy + next);
            dz = _mm512_mask_expandloadu_pd(dz, fr, Q_dz + next);
            tend = _mm512_mask_expandloadu_pd(tend, fr, Q_tend + next);
            cx = _mm512_mask_expandloadu_epi64(cx, fr, Q_cx + next);
            cy = _mm512_mask_expandloadu_epi64(cy, fr, Q_cy + next);
            sx = _mm512_mask_expandloadu_epi64(sx, fr, Q_sx + next);
            sy = _mm512_mask_expandloadu_epi64(sy, fr, Q_sy + next);
            qid = _mm512_mask_mov_epi64(qid, fr, _mm512_add_epi64(_mm512_set1_epi64(next), _mm512_maskz_expand_epi64(fr, lane)));
            act |= fr;
            next += nf;
        }
        if (!act) break;
        /* te = min(tmx, tmy, tend); the ray's lowest z in the cell against the cell's max height */
        __m512d te = _mm512_min_pd(_mm512_min_pd(tmx, tmy), tend);
        __mmask8 desc = _mm512_cmp_pd_mask(dz, zero, _CMP_LT_OQ);
        __m512d zlow = _mm512_add_pd(voz, _mm512_mul_pd(dz, _mm512_mask_blend_pd(desc, t, te)));
        __m512i hb = _mm512_add_epi64(_mm512_mullo_epi64(cy, vW), cx);
        /* the corner pairs (h00, h10) and (h01, h11) are adjacent floats: one 64-bit gather each */
        __m512i r0 = _mm512_mask_i64gather_epi64(izero, act, hb, h, 4);
        __m512i r1 = _mm512_mask_i64gather_epi64(izero, act, hb, h + W, 4);
        __m512d h00 = _mm512_cvtps_pd(_mm256_castsi256_ps(_mm512_cvtepi64_epi32(r0)));
        __m512d h10 = _mm512_cvtps_pd(_mm256_castsi256_ps(_mm512_cvtepi64_epi32(_mm512_srli_epi64(r0, 32))));
        __m512d h01 = _mm512_cvtps_pd(_mm256_castsi256_ps(_mm512_cvtepi64_epi32(r1)));
        __m512d h11 = _mm512_cvtps_pd(_mm256_castsi256_ps(_mm512_cvtepi64_epi32(_mm512_srli_epi64(r1, 32))));
        __m512d cmax = _mm512_max_pd(_mm512_max_pd(h00, h10), _mm512_max_pd(h01, h11));
        __mmask8 cand = _mm512_mask_cmp_pd_mask(act, zlow, cmax, _CMP_LE_OQ);
        if (cand) {  /* the exact cell test (_raycast._cell_hit with selects; a flat cell first) */
            __mmask8 flat = _mm512_mask_cmp_pd_mask(cand, h00, cmax, _CMP_EQ_OQ) & _mm512_cmp_pd_mask(h10, cmax, _CMP_EQ_OQ) &
                            _mm512_cmp_pd_mask(h01, cmax, _CMP_EQ_OQ) & _mm512_cmp_pd_mask(h11, cmax, _CMP_EQ_OQ);
            __m512d ts = t;
            __mmask8 flat_hit = 0;
            if (flat) {  /* a flat cell: the plane z = cmax (rare: obstacle pads, flat maps) */
                __m512d xq = _mm512_div_pd(_mm512_sub_pd(h00, voz), dz);
                ts = _mm512_mask_blend_pd(desc, t, _mm512_mask_blend_pd(_mm512_cmp_pd_mask(xq, t, _CMP_GT_OQ), t, xq));
                flat_hit = _mm512_mask_cmp_pd_mask(flat, ts, te, _CMP_LE_OQ);
            }
            __m512d fcx = _mm512_cvtepi64_pd(cx), fcy = _mm512_cvtepi64_pd(cy);
            __m512d ta = t, tb = te;
            __m512d ua = _mm512_sub_pd(_mm512_add_pd(vox, _mm512_mul_pd(ta, dx)), fcx);
            __m512d va = _mm512_sub_pd(_mm512_add_pd(voy, _mm512_mul_pd(ta, dy)), fcy);
            __m512d ub = _mm512_sub_pd(_mm512_add_pd(vox, _mm512_mul_pd(tb, dx)), fcx);
            __m512d vb = _mm512_sub_pd(_mm512_add_pd(voy, _mm512_mul_pd(tb, dy)), fcy);
            __m512d wa = _mm512_sub_pd(ua, va), wb = _mm512_sub_pd(ub, vb);
            __mmask8 cross = (_mm512_cmp_pd_mask(wa, zero, _CMP_GT_OQ) & _mm512_cmp_pd_mask(wb, zero, _CMP_LT_OQ)) |
                             (_mm512_cmp_pd_mask(wa, zero, _CMP_LT_OQ) & _mm512_cmp_pd_mask(wb, zero, _CMP_GT_OQ));
            __m512d den = _mm512_mask_blend_pd(cross, one, _mm512_sub_pd(wa, wb));
            __m512d td = _mm512_mask_blend_pd(cross, tb,
                                              _mm512_add_pd(ta, _mm512_mul_pd(_mm512_sub_pd(tb, ta), _mm512_div_pd(wa, den))));
            __m512d ud = _mm512_mask_blend_pd(cross, ub, _mm512_sub_pd(_mm512_add_pd(vox, _mm512_mul_pd(td, dx)), fcx));
            __m512d vd = _mm512_mask_blend_pd(cross, vb, _mm512_sub_pd(_mm512_add_pd(voy, _mm512_mul_pd(td, dy)), fcy));
            __m512d A = _mm512_sub_pd(h10, h00), Bl = _mm512_sub_pd(h11, h10), Bu = _mm512_sub_pd(h01, h00);
            __m512d Au = _mm512_sub_pd(h11, h01);
            /* piece 1 (ta..td) in the triangle of its midpoint, piece 2 (td..tb, only when crossing) likewise */
            __mmask8 lo1 = _mm512_cmp_pd_mask(_mm512_add_pd(wa, _mm512_sub_pd(ud, vd)), zero, _CMP_GE_OQ);
            __m512d g0 = _mm512_mask_blend_pd(lo1, GUP(ua, va), GLO(ua, va));
            __m512d g1 = _mm512_mask_blend_pd(lo1, GUP(ud, vd), GLO(ud, vd));
            __m512d f0 = _mm512_sub_pd(_mm512_add_pd(voz, _mm512_mul_pd(ta, dz)), g0);
            __m512d f1 = _mm512_sub_pd(_mm512_add_pd(voz, _mm512_mul_pd(td, dz)), g1);
            __mmask8 lo2 = _mm512_cmp_pd_mask(_mm512_add_pd(_mm512_sub_pd(ud, vd), wb), zero, _CMP_GE_OQ);
            __m512d g2 = _mm512_mask_blend_pd(lo2, GUP(ud, vd), GLO(ud, vd));
            __m512d g3 = _mm512_mask_blend_pd(lo2, GUP(ub, vb), GLO(ub, vb));
            __m512d f2 = _mm512_sub_pd(_mm512_add_pd(voz, _mm512_mul_pd(td, dz)), g2);
            __m512d f3 = _mm512_sub_pd(_mm512_add_pd(voz, _mm512_mul_pd(tb, dz)), g3);
            /* the crossing on piece 1 (f1 <= 0) or else piece 2: one division for either */
            __mmask8 p1 = _mm512_cmp_pd_mask(f1, zero, _CMP_LE_OQ);
            __m512d s0 = _mm512_mask_blend_pd(p1, td, ta), s1 = _mm512_mask_blend_pd(p1, tb, td);
            __m512d e0 = _mm512_mask_blend_pd(p1, f2, f0), e1 = _mm512_mask_blend_pd(p1, f3, f1);
            __m512d rr = _mm512_add_pd(s0, _mm512_mul_pd(_mm512_sub_pd(s1, s0), _mm512_div_pd(e0, _mm512_sub_pd(e0, e1))));
            __m512d tcell = vinf;
            tcell = _mm512_mask_mov_pd(tcell, cross & _mm512_cmp_pd_mask(f3, zero, _CMP_LE_OQ), rr);
            tcell = _mm512_mask_mov_pd(tcell, cross & _mm512_cmp_pd_mask(f2, zero, _CMP_LE_OQ), td);
            tcell = _mm512_mask_mov_pd(tcell, p1, rr);
            tcell = _mm512_mask_mov_pd(tcell, _mm512_cmp_pd_mask(f0, zero, _CMP_LE_OQ), ta);
            __mmask8 hit = flat_hit | _mm512_mask_cmp_pd_mask(cand, tcell, te, _CMP_LE_OQ);
            if (hit) {
                __m512d res = _mm512_mask_blend_pd(flat_hit, tcell, ts);
                _mm512_mask_i64scatter_pd(R_th, hit, qid, res, 8);
                act &= (__mmask8)~hit;
            }
        }
        /* step to the next cell; the walk ends at tend or at the map's edge */
        __mmask8 endm = _mm512_mask_cmp_pd_mask(act, te, tend, _CMP_GE_OQ);
        __mmask8 stx = _mm512_cmp_pd_mask(tmx, tmy, _CMP_LE_OQ), sty = _mm512_cmp_pd_mask(tmy, tmx, _CMP_LE_OQ);
        cx = _mm512_mask_add_epi64(cx, stx, cx, sx);
        tmx = _mm512_mask_add_pd(tmx, stx, tmx, tdx);
        cy = _mm512_mask_add_epi64(cy, sty, cy, sy);
        tmy = _mm512_mask_add_pd(tmy, sty, tmy, tdy);
        __mmask8 oob = _mm512_cmp_epi64_mask(cx, izero, _MM_CMPINT_LT) | _mm512_cmp_epi64_mask(cx, vncx, _MM_CMPINT_NLT) |
                       _mm512_cmp_epi64_mask(cy, izero, _MM_CMPINT_LT) | _mm512_cmp_epi64_mask(cy, vncy, _MM_CMPINT_NLT);
        act &= (__mmask8)~(endm | oob);  /* finished without a hit: R_th stays +inf */
        t = te;
    }
}
#else
void nv_march_channel(const float *h, int64_t W, int64_t ncx, int64_t ncy, double oz, double oxc,
                      double oyc, int64_t nq, const double *Q, const int64_t *I, int64_t qs, double *R) {
    (void)h; (void)W; (void)ncx; (void)ncy; (void)oz; (void)oxc; (void)oyc; (void)nq; (void)Q; (void)I;
    (void)qs; (void)R;
}
#endif
