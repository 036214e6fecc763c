#include "vision/yuvd_background.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <new>
#include <string>
#include <utility>

#include <opencv2/imgproc.hpp>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace vigil::vision {

namespace {

// ---------------------------------------------------------------------------------------------
// Storage: one float plane (height x stride) per field and Gaussian, field-major, so that the
// depth fields can be appended when depth first appears.

enum Field { kW = 0, kMY, kMU, kMV, kVY, kVC, kMD, kVD, kFD };
constexpr int kColourFields = 6;
constexpr int kAllFields = 9;
constexpr int kMaxK = 8;
constexpr std::size_t kAlign = 64;

struct AlignedDelete {
  void operator()(float* p) const { ::operator delete[](p, std::align_val_t{kAlign}); }
};
using AlignedFloats = std::unique_ptr<float[], AlignedDelete>;

AlignedFloats alloc_floats(std::size_t n) {
  auto* p = static_cast<float*>(::operator new[](n * sizeof(float), std::align_val_t{kAlign}));
  std::fill(p, p + n, 0.0f);
  return AlignedFloats(p);
}

// ---------------------------------------------------------------------------------------------
// The kernel: N pixels at a time (4 with SSE2, 8 with AVX2) with GCC/Clang vector extensions,
// branch-free except for the fast path taken when all N pixels match their strongest Gaussian
// (which gives exactly what the general path would). Every arithmetic step is the
// same IEEE operation whatever the instruction set (no fused multiply-add, no reassociation), so
// the SSE2 and AVX2 builds of the kernel give identical bytes. Vectors are passed by reference
// between the (always inlined) helpers, which keeps GCC's psABI notes away, and the warning
// about returning them from non-AVX code is moot for the same reason.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wpsabi"
#endif

#define VIGIL_INLINE inline __attribute__((always_inline))

// The vector types of a kernel of N lanes.
template <int N>
struct Lanes;
template <>
struct Lanes<4> {
  typedef float f __attribute__((vector_size(16)));
  typedef int i __attribute__((vector_size(16)));
  typedef uint8_t b __attribute__((vector_size(4)));
};
template <>
struct Lanes<8> {
  typedef float f __attribute__((vector_size(32)));
  typedef int i __attribute__((vector_size(32)));
  typedef uint8_t b __attribute__((vector_size(8)));
};

// Per-frame constants of the kernel (variances, not sigmas).
struct Consts {
  float T;             // match threshold
  float T_agree;       // match threshold x depth_agree_factor
  float dvf;           // depth valid fraction
  float ymin;          // minimum luminance for chroma
  float rho;           // activity rate
  float act_thr;       // activity threshold
  float a_hi, a_lo;    // learning rate of quiet and of active pixels this frame
  float bg_w;          // background cumulative weight
  float init_w;
  float vy_init, vy_min, vy_max;
  float vc_init, vc_min, vc_max;
  float vd_init, sd_min, sd_rel, vd_max;
  bool block;          // nearer flag blocks replacement
};

struct RowArgs {
  float* p[kAllFields][kMaxK];  // row start of each plane
  float* act;
  const uint8_t *Y, *U, *V, *PY;  // this row of the frame's Y, U, V planes and the previous Y
  const float* D;                 // this row of the depth image (raw, may hold invalid values)
  const uint8_t* M;               // this row of the measured mask (nonzero = depth measured), or null
  uint8_t* mask;
  int width;
};

// The kernel on N pixels at a time (N = 4: SSE2, N = 8: AVX2; the same arithmetic per lane).
template <int N>
struct Kernel {
  using vf = typename Lanes<N>::f;
  using vi = typename Lanes<N>::i;
  using vb = typename Lanes<N>::b;

  static VIGIL_INLINE vf splat(float s) {
    if constexpr (N == 8)
      return vf{s, s, s, s, s, s, s, s};
    else
      return vf{s, s, s, s};
  }
  static VIGIL_INLINE vi splat_i(int s) {
    if constexpr (N == 8)
      return vi{s, s, s, s, s, s, s, s};
    else
      return vi{s, s, s, s};
  }
  static VIGIL_INLINE vf ld(const float* p) {
    vf v;
    std::memcpy(&v, p, sizeof v);
    return v;
  }
  static VIGIL_INLINE void st(float* p, const vf& v) { std::memcpy(p, &v, sizeof v); }
  static VIGIL_INLINE vf ld_u8(const uint8_t* p) {
    vb v;
    std::memcpy(&v, p, sizeof v);
    return __builtin_convertvector(__builtin_convertvector(v, vi), vf);
  }
  static VIGIL_INLINE vf sel(const vi& m, const vf& a, const vf& b) { return m ? a : b; }
  static VIGIL_INLINE vi sel_i(const vi& m, const vi& a, const vi& b) { return m ? a : b; }
  static VIGIL_INLINE vf vabs(const vf& x) { return sel(x < splat(0.0f), -x, x); }
  static VIGIL_INLINE vf clamp(const vf& x, const vf& lo, const vf& hi) {
    return sel(x < lo, lo, sel(x > hi, hi, x));
  }
  // Bit l set when lane l of the mask is set.
  static VIGIL_INLINE int mask_bits(const vi& m) {
#if defined(__SSE2__)
    __m128 lo;
    std::memcpy(&lo, &m, sizeof lo);
    if constexpr (N == 4) {
      return _mm_movemask_ps(lo);
    } else {
      __m128 hi;
      std::memcpy(&hi, reinterpret_cast<const char*>(&m) + sizeof lo, sizeof hi);
      return _mm_movemask_ps(lo) | (_mm_movemask_ps(hi) << 4);
    }
#else
    int bits = 0;
    for (int l = 0; l < N; ++l) bits |= (m[l] ? 1 : 0) << l;
    return bits;
#endif
  }
  static VIGIL_INLINE bool all_true(const vi& m) { return mask_bits(m) == (1 << N) - 1; }
  static VIGIL_INLINE bool any_true(const vi& m) { return mask_bits(m) != 0; }

  struct Obs {
    vf Y, U, V, D;
    vi dval;       // valid depth
    vi dmeas;      // depth measured (valid or not): its statistics may learn
    vi chroma;     // Y >= ymin
  };

  struct Gauss {
    vf w, mY, mU, mV, vY, vC, mD, vD, fD;
  };

  struct Test {
    vi ok;      // matches
    vi nearer;  // depth usable, disagrees and is nearer
    vi agree;   // depth usable and agrees
  };

  template <bool kDepth>
  static VIGIL_INLINE Gauss load_gauss(const RowArgs& r, int k, int x) {
    Gauss g;
    g.w = ld(r.p[kW][k] + x);
    g.mY = ld(r.p[kMY][k] + x);
    g.mU = ld(r.p[kMU][k] + x);
    g.mV = ld(r.p[kMV][k] + x);
    g.vY = ld(r.p[kVY][k] + x);
    g.vC = ld(r.p[kVC][k] + x);
    if constexpr (kDepth) {
      g.mD = ld(r.p[kMD][k] + x);
      g.vD = ld(r.p[kVD][k] + x);
      g.fD = ld(r.p[kFD][k] + x);
    } else {
      g.mD = g.vD = g.fD = splat(0.0f);
    }
    return g;
  }

  template <bool kDepth>
  static VIGIL_INLINE void store_gauss(const RowArgs& r, int k, int x, const Gauss& g) {
    st(r.p[kW][k] + x, g.w);
    st(r.p[kMY][k] + x, g.mY);
    st(r.p[kMU][k] + x, g.mU);
    st(r.p[kMV][k] + x, g.mV);
    st(r.p[kVY][k] + x, g.vY);
    st(r.p[kVC][k] + x, g.vC);
    if constexpr (kDepth) {
      st(r.p[kMD][k] + x, g.mD);
      st(r.p[kVD][k] + x, g.vD);
      st(r.p[kFD][k] + x, g.fD);
    }
  }

  // The chapter's match test of one Gaussian.
  template <bool kDepth>
  static VIGIL_INLINE Test match(const Consts& c, const Obs& o, const Gauss& g) {
    Test t;
    vf tol = splat(c.T);
    vi dis = splat_i(0);
    t.agree = splat_i(0);
    t.nearer = splat_i(0);
    if constexpr (kDepth) {
      // (fD > 0 as well: a Gaussian that never saw a valid depth has no depth mean at all)
      const vi use = o.dval & (g.fD >= splat(c.dvf)) & (g.fD > splat(0.0f));
      const vf dd = o.D - g.mD;
      t.agree = use & (dd * dd < splat(c.T) * g.vD);
      dis = use & ~t.agree;
      t.nearer = dis & (o.D < g.mD);
      tol = sel(t.agree, splat(c.T_agree), tol);
    }
    const vf dy = o.Y - g.mY;
    const vi y_ok = dy * dy < tol * g.vY;
    const vf du = o.U - g.mU;
    const vf dv = o.V - g.mV;
    const vi chroma_used = o.chroma & (g.mY >= splat(c.ymin));
    const vi c_ok = ~chroma_used | (du * du + dv * dv < tol * g.vC);
    t.ok = (g.w > splat(0.0f)) & ~dis & y_ok & c_ok;
    return t;
  }

  // Eq. 10.2 for the lanes in m (means first use the old mean for the variances).
  template <bool kDepth>
  static VIGIL_INLINE void update_gauss(const Consts& c, const Obs& o, const vi& m, const vf& a,
                                 Gauss& g) {
    const vf dy = o.Y - g.mY;
    const vf du = o.U - g.mU;
    const vf dv = o.V - g.mV;
    g.mY = sel(m, g.mY + a * dy, g.mY);
    g.mU = sel(m, g.mU + a * du, g.mU);
    g.mV = sel(m, g.mV + a * dv, g.mV);
    g.vY = sel(m, clamp(g.vY + a * (dy * dy - g.vY), splat(c.vy_min), splat(c.vy_max)), g.vY);
    g.vC = sel(m, clamp(g.vC + a * (du * du + dv * dv - g.vC), splat(c.vc_min), splat(c.vc_max)),
               g.vC);
    if constexpr (kDepth) {
      const vi first = g.fD <= splat(0.0f);  // no valid depth seen yet: start the statistics
      const vf dd = o.D - g.mD;
      const vf mD = sel(first, o.D, g.mD + a * dd);
      const vf floor_sd = splat(c.sd_min) + splat(c.sd_rel) * mD;
      const vf vD = sel(first, splat(c.vd_init),
                        clamp(g.vD + a * (dd * dd - g.vD), floor_sd * floor_sd, splat(c.vd_max)));
      const vi md = m & o.dval;
      g.mD = sel(md, mD, g.mD);
      g.vD = sel(md, vD, g.vD);
      const vf valid = sel(o.dval, splat(1.0f), splat(0.0f));
      g.fD = sel(m & o.dmeas, g.fD + a * (valid - g.fD), g.fD);
    }
  }

  // Eq. 10.3 for the lanes in m: w <- w + a (M - w).
  static VIGIL_INLINE vf update_weight(const vi& m, const vf& a, const vf& M, const vf& w) {
    return sel(m, w + a * (M - w), w);
  }

  // Ordering key comparison: Gaussian b before Gaussian a (w_b / sigma_b > w_a / sigma_a).
  static VIGIL_INLINE vi stronger(const Gauss& b, const Gauss& a) {
    return b.w * b.w * a.vY > a.w * a.w * b.vY;
  }

  static VIGIL_INLINE void swap_where(const vi& s, Gauss& a, Gauss& b) {
    auto sw = [s](vf& x, vf& y) {
      const vf nx = sel(s, y, x);
      y = sel(s, x, y);
      x = nx;
    };
    sw(a.w, b.w);
    sw(a.mY, b.mY);
    sw(a.mU, b.mU);
    sw(a.mV, b.mV);
    sw(a.vY, b.vY);
    sw(a.vC, b.vC);
    sw(a.mD, b.mD);
    sw(a.vD, b.vD);
    sw(a.fD, b.fD);
  }

  static VIGIL_INLINE void write_mask(uint8_t* mask, int n, const vi& fg) {
    const vb m = __builtin_convertvector(fg, vb);  // -1 -> 255
    std::memcpy(mask, &m, static_cast<std::size_t>(n));
  }

  template <int K, bool kDepth>
  static VIGIL_INLINE void row(const Consts& c, const RowArgs& args) {
    const RowArgs r = args;  // a local copy: the plane pointers cannot alias the planes' floats
    const vi all_ones = splat_i(-1);
    // The last step may reach past the row: it reads from zero-padded copies (the padding lanes
    // are computed and discarded).
    uint8_t tail_u8[5][N];
    float tail_d[N];
    for (int x = 0; x < r.width; x += N) {
      const uint8_t *py = r.Y + x, *pu = r.U + x, *pv = r.V + x, *ppy = r.PY + x;
      const float* pd = r.D + x;
      const uint8_t* pm = r.M ? r.M + x : nullptr;
      const int n = std::min(N, r.width - x);
      if (n < N) {
        std::memset(tail_u8, 0, sizeof tail_u8);
        std::memcpy(tail_u8[0], py, n);
        std::memcpy(tail_u8[1], pu, n);
        std::memcpy(tail_u8[2], pv, n);
        std::memcpy(tail_u8[3], ppy, n);
        py = tail_u8[0];
        pu = tail_u8[1];
        pv = tail_u8[2];
        ppy = tail_u8[3];
        if constexpr (kDepth) {
          std::fill(tail_d, tail_d + N, 0.0f);
          std::memcpy(tail_d, pd, n * sizeof(float));
          pd = tail_d;
          if (pm) {
            std::memcpy(tail_u8[4], pm, n);
            pm = tail_u8[4];
          }
        }
      }
      Obs o;
      o.Y = ld_u8(py);
      o.U = ld_u8(pu);
      o.V = ld_u8(pv);
      o.chroma = o.Y >= splat(c.ymin);
      if constexpr (kDepth) {
        const vf d = ld(pd);
        // valid: positive and finite (NaN fails both comparisons); invalid depth becomes 0
        o.dval = (d > splat(0.0f)) & (d < splat(std::numeric_limits<float>::infinity()));
        o.dmeas = pm ? (ld_u8(pm) > splat(0.0f)) : splat_i(-1);
        o.dval &= o.dmeas;
        o.D = sel(o.dval, d, splat(0.0f));
      } else {
        o.D = splat(0.0f);
        o.dval = splat_i(0);
        o.dmeas = splat_i(0);
      }
      // Eq. 10.4 and the activity-modulated learning rate.
      vf ac = ld(r.act + x);
      ac = ac + splat(c.rho) * (vabs(o.Y - ld_u8(ppy)) - ac);
      st(r.act + x, ac);
      const vf a = sel(ac > splat(c.act_thr), splat(c.a_lo), splat(c.a_hi));

      // Fast path: every lane matches its strongest Gaussian (always a background one).
      Gauss g0 = load_gauss<kDepth>(r, 0, x);
      const Test t0 = match<kDepth>(c, o, g0);
      if (all_true(t0.ok)) {
        Gauss n0 = g0;
        n0.w = update_weight(all_ones, a, splat(1.0f), n0.w);
        update_gauss<kDepth>(c, o, all_ones, a, n0);
        bool keep_order = true;
        vf w1 = splat(0.0f);
        if constexpr (K > 1) {
          Gauss g1;
          g1.w = update_weight(all_ones, a, splat(0.0f), ld(r.p[kW][1] + x));
          g1.vY = ld(r.p[kVY][1] + x);
          w1 = g1.w;
          keep_order = !any_true(stronger(g1, n0));
        }
        if (keep_order) {
          store_gauss<kDepth>(r, 0, x, n0);
          if constexpr (K > 1) {
            st(r.p[kW][1] + x, w1);
            for (int k = 2; k < K; ++k)
              st(r.p[kW][k] + x, update_weight(all_ones, a, splat(0.0f), ld(r.p[kW][k] + x)));
          }
          write_mask(r.mask + x, n, splat_i(0));
          continue;
        }
      }

      // General path: all K Gaussians in sorted order.
      Gauss g[K];
      g[0] = g0;
      for (int k = 1; k < K; ++k) g[k] = load_gauss<kDepth>(r, k, x);
      vi matched = splat_i(0), match_bg = splat_i(0), agree_bg = splat_i(0), flag = splat_i(0);
      vi mk[K];
      vi changed = splat_i(-1);  // index of the Gaussian that changed its key
      vf cum = splat(0.0f);
      for (int k = 0; k < K; ++k) {
        const vi is_bg = cum < splat(c.bg_w);
        cum = cum + g[k].w;
        const Test t = k == 0 ? t0 : match<kDepth>(c, o, g[k]);
        const vi fresh = ~matched;
        const vi ok = t.ok & fresh;
        flag |= t.nearer & is_bg & fresh;
        match_bg |= ok & is_bg;
        agree_bg |= ok & is_bg & t.agree;
        matched |= ok;
        mk[k] = ok;
        changed = sel_i(ok, splat_i(k), changed);
      }
      const vi fg = ~match_bg | (flag & ~agree_bg);
      vi repl = ~matched;
      if (c.block) repl &= ~flag;
      const vi decay = matched | repl;
      for (int k = 0; k < K; ++k) {
        g[k].w = update_weight(decay, a, sel(mk[k], splat(1.0f), splat(0.0f)), g[k].w);
        update_gauss<kDepth>(c, o, mk[k], a, g[k]);
      }
      // Nothing matched: the weakest Gaussian becomes one centred on the observation.
      if (any_true(repl)) {
        Gauss& L = g[K - 1];
        L.w = sel(repl, sel(a > splat(c.init_w), a, splat(c.init_w)), L.w);
        L.mY = sel(repl, o.Y, L.mY);
        L.mU = sel(repl, o.U, L.mU);
        L.mV = sel(repl, o.V, L.mV);
        L.vY = sel(repl, splat(c.vy_init), L.vY);
        L.vC = sel(repl, splat(c.vc_init), L.vC);
        if constexpr (kDepth) {
          L.mD = sel(repl, sel(o.dval, o.D, splat(0.0f)), L.mD);
          L.vD = sel(repl, splat(c.vd_init), L.vD);
          L.fD = sel(repl, sel(o.dval, splat(1.0f), splat(0.0f)), L.fD);
        }
        vf sum = g[0].w;
        for (int k = 1; k < K; ++k) sum = sum + g[k].w;
        for (int k = 0; k < K; ++k) g[k].w = sel(repl, g[k].w / sum, g[k].w);
        changed = sel_i(repl, splat_i(K - 1), changed);
      }
      // Re-insert the changed Gaussian at its place: up, then down.
      for (int j = K - 2; j >= 0; --j) {
        const vi s = (changed == splat_i(j + 1)) & stronger(g[j + 1], g[j]);
        swap_where(s, g[j], g[j + 1]);
        changed = sel_i(s, splat_i(j), changed);
      }
      for (int j = 0; j + 1 < K; ++j) {
        const vi s = (changed == splat_i(j)) & stronger(g[j + 1], g[j]);
        swap_where(s, g[j], g[j + 1]);
        changed = sel_i(s, splat_i(j + 1), changed);
      }
      for (int k = 0; k < K; ++k) store_gauss<kDepth>(r, k, x, g[k]);
      write_mask(r.mask + x, n, fg);
    }
  }
};

template <int K, bool kDepth>
void row_kernel_portable(const Consts& c, const RowArgs& r) {
  Kernel<4>::row<K, kDepth>(c, r);
}

#if defined(__x86_64__) && defined(__GNUC__)
#define VIGIL_HAVE_AVX2_KERNEL 1
template <int K, bool kDepth>
__attribute__((target("avx2"))) void row_kernel_avx2(const Consts& c, const RowArgs& r) {
  Kernel<8>::row<K, kDepth>(c, r);
}
#endif

using RowKernel = void (*)(const Consts&, const RowArgs&);

template <int K>
RowKernel pick_kernel(bool depth, bool avx2) {
#ifdef VIGIL_HAVE_AVX2_KERNEL
  if (avx2) return depth ? &row_kernel_avx2<K, true> : &row_kernel_avx2<K, false>;
#endif
  (void)avx2;
  return depth ? &row_kernel_portable<K, true> : &row_kernel_portable<K, false>;
}

RowKernel select_kernel(int K, bool depth, bool avx2) {
  switch (K) {
    case 1: return pick_kernel<1>(depth, avx2);
    case 2: return pick_kernel<2>(depth, avx2);
    case 3: return pick_kernel<3>(depth, avx2);
    case 4: return pick_kernel<4>(depth, avx2);
    case 5: return pick_kernel<5>(depth, avx2);
    case 6: return pick_kernel<6>(depth, avx2);
    case 7: return pick_kernel<7>(depth, avx2);
    default: return pick_kernel<8>(depth, avx2);
  }
}

bool cpu_has_avx2() {
#ifdef VIGIL_HAVE_AVX2_KERNEL
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
#else
  return false;
#endif
}

bool& force_portable_flag() {
  static bool force = false;
  return force;
}

Error bad_param(const std::string& key, const std::string& message) {
  return bad_input("", 0, key, message);
}

std::string num(double v) {
  std::string s = std::to_string(v);
  while (s.size() > 1 && s.back() == '0') s.pop_back();
  if (!s.empty() && s.back() == '.') s.pop_back();
  return s;
}

std::string describe(const cv::Mat& m) {
  return std::to_string(m.cols) + "x" + std::to_string(m.rows) + " " +
         cv::typeToString(m.type());
}

bool valid_depth(float d) { return d > 0.0f && d < std::numeric_limits<float>::infinity(); }

}  // namespace

namespace detail {
void yuvd_force_portable_kernel(bool force) { force_portable_flag() = force; }
}  // namespace detail

// ---------------------------------------------------------------------------------------------

Status YuvdBackgroundParams::validate() const {
  auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
  if (num_gaussians < 1 || num_gaussians > kMaxK)
    return bad_param("num_gaussians", "must be in 1..8, got " + std::to_string(num_gaussians));
  if (!(learning_rate > 0.0f) || !in(learning_rate, 0, 1))
    return bad_param("learning_rate", "must be in (0, 1], got " + num(learning_rate));
  if (!(match_threshold > 0.0f) || !std::isfinite(match_threshold))
    return bad_param("match_threshold", "must be positive, got " + num(match_threshold));
  if (!in(depth_valid_fraction, 0, 1))
    return bad_param("depth_valid_fraction", "must be in [0, 1], got " + num(depth_valid_fraction));
  if (!in(depth_agree_factor, 1, 1e6))
    return bad_param("depth_agree_factor", "must be >= 1, got " + num(depth_agree_factor));
  if (!in(min_chroma_luminance, 0, 256))
    return bad_param("min_chroma_luminance",
                     "must be in [0, 256], got " + num(min_chroma_luminance));
  if (!in(activity_rate, 0, 1))
    return bad_param("activity_rate", "must be in [0, 1], got " + num(activity_rate));
  if (!in(activity_threshold, 0, 1e6))
    return bad_param("activity_threshold", "must be >= 0, got " + num(activity_threshold));
  if (!in(activity_divisor, 1, 1e6))
    return bad_param("activity_divisor", "must be >= 1, got " + num(activity_divisor));
  if (!(background_weight > 0.0f) || !in(background_weight, 0, 1))
    return bad_param("background_weight", "must be in (0, 1], got " + num(background_weight));
  if (!(init_weight > 0.0f) || !in(init_weight, 0, 1))
    return bad_param("init_weight", "must be in (0, 1], got " + num(init_weight));
  struct Sig {
    const char* lo_key;
    float lo;
    const char* init_key;
    float init;
    const char* hi_key;
    float hi;
  };
  const Sig sigs[] = {
      {"min_sigma_y", min_sigma_y, "init_sigma_y", init_sigma_y, "max_sigma_y", max_sigma_y},
      {"min_sigma_c", min_sigma_c, "init_sigma_c", init_sigma_c, "max_sigma_c", max_sigma_c},
      {"min_sigma_depth", min_sigma_depth, "init_sigma_depth", init_sigma_depth,
       "max_sigma_depth", max_sigma_depth},
  };
  for (const Sig& s : sigs) {
    if (!(s.lo > 0.0f) || !std::isfinite(s.lo))
      return bad_param(s.lo_key, "must be positive, got " + num(s.lo));
    if (!(s.hi >= s.lo) || !std::isfinite(s.hi))
      return bad_param(s.hi_key, "must be finite and >= " + std::string(s.lo_key) + " (" +
                                     num(s.lo) + "), got " + num(s.hi));
    if (!in(s.init, s.lo, s.hi))
      return bad_param(s.init_key, "must be between " + std::string(s.lo_key) + " and " +
                                       s.hi_key + ", got " + num(s.init));
  }
  if (!in(min_sigma_depth_rel, 0, 1))
    return bad_param("min_sigma_depth_rel", "must be in [0, 1], got " + num(min_sigma_depth_rel));
  if (bootstrap_frames < 0)
    return bad_param("bootstrap_frames", "must be >= 0, got " + std::to_string(bootstrap_frames));
  if (open_radius < 0 || open_radius > 50)
    return bad_param("open_radius", "must be in 0..50, got " + std::to_string(open_radius));
  if (close_radius < 0 || close_radius > 50)
    return bad_param("close_radius", "must be in 0..50, got " + std::to_string(close_radius));
  if (min_component_area < 0)
    return bad_param("min_component_area",
                     "must be >= 0, got " + std::to_string(min_component_area));
  return Status::Ok();
}

// ---------------------------------------------------------------------------------------------

struct YuvdBackground::Buffers {
  AlignedFloats planes;    // fields x K planes of plane_size floats
  AlignedFloats activity;  // one plane
  AlignedFloats zero_depth;  // one row of zeros: the depth of frames given without depth
  std::size_t plane_size = 0;
  int fields = 0;

  float* plane(int field, int k, int K) {
    return planes.get() + (static_cast<std::size_t>(field) * K + k) * plane_size;
  }
  const float* plane(int field, int k, int K) const {
    return planes.get() + (static_cast<std::size_t>(field) * K + k) * plane_size;
  }
};

YuvdBackground::YuvdBackground(const YuvdBackgroundParams& params)
    : params_(params), buf_(std::make_unique<Buffers>()) {
  if (params_.open_radius > 0)
    open_kernel_ = cv::getStructuringElement(
        cv::MORPH_ELLIPSE, {2 * params_.open_radius + 1, 2 * params_.open_radius + 1});
  if (params_.close_radius > 0)
    close_kernel_ = cv::getStructuringElement(
        cv::MORPH_ELLIPSE, {2 * params_.close_radius + 1, 2 * params_.close_radius + 1});
}

YuvdBackground::YuvdBackground(YuvdBackground&&) noexcept = default;
YuvdBackground& YuvdBackground::operator=(YuvdBackground&&) noexcept = default;
YuvdBackground::~YuvdBackground() = default;

Result<YuvdBackground> YuvdBackground::create(const YuvdBackgroundParams& params) {
  if (Status s = params.validate(); !s) return s.error();
  return YuvdBackground(params);
}

void YuvdBackground::reset() {
  frames_ = 0;
  width_ = height_ = stride_ = 0;
  has_depth_ = false;
  buf_ = std::make_unique<Buffers>();
  yuv_.release();
  prev_y_.release();
  for (cv::Mat& m : planes_) m.release();
  raw_mask_.release();
}

void YuvdBackground::allocate(int width, int height) {
  width_ = width;
  height_ = height;
  stride_ = (width + 15) / 16 * 16;  // whole kernel steps and 64-byte aligned rows
  buf_->plane_size = static_cast<std::size_t>(stride_) * height_;
  buf_->fields = kColourFields;
  buf_->planes = alloc_floats(buf_->plane_size * kColourFields * params_.num_gaussians);
  buf_->activity = alloc_floats(buf_->plane_size);
  buf_->zero_depth = alloc_floats(static_cast<std::size_t>(stride_));
}

void YuvdBackground::add_depth_planes() {
  const int K = params_.num_gaussians;
  const std::size_t ps = buf_->plane_size;
  AlignedFloats planes = alloc_floats(ps * kAllFields * K);
  std::memcpy(planes.get(), buf_->planes.get(), ps * kColourFields * K * sizeof(float));
  buf_->planes = std::move(planes);
  buf_->fields = kAllFields;
  const float vd_init = params_.init_sigma_depth * params_.init_sigma_depth;
  for (int k = 0; k < K; ++k) std::fill_n(buf_->plane(kVD, k, K), ps, vd_init);
  // means and valid fractions stay 0: "no valid depth seen yet".
  has_depth_ = true;
}

void YuvdBackground::first_frame(const cv::Mat& depth) {
  const int K = params_.num_gaussians;
  const float vy = params_.init_sigma_y * params_.init_sigma_y;
  const float vc = params_.init_sigma_c * params_.init_sigma_c;
  const float vd = params_.init_sigma_depth * params_.init_sigma_depth;
  for (int y = 0; y < height_; ++y) {
    const uint8_t* Y = planes_[0].ptr<uint8_t>(y);
    const uint8_t* U = planes_[1].ptr<uint8_t>(y);
    const uint8_t* V = planes_[2].ptr<uint8_t>(y);
    const float* D = depth.empty() ? buf_->zero_depth.get() : depth.ptr<float>(y);
    const std::size_t off = static_cast<std::size_t>(y) * stride_;
    for (int k = 0; k < K; ++k) {
      float* w = buf_->plane(kW, k, K) + off;
      float* my = buf_->plane(kMY, k, K) + off;
      float* mu = buf_->plane(kMU, k, K) + off;
      float* mv = buf_->plane(kMV, k, K) + off;
      float* vY = buf_->plane(kVY, k, K) + off;
      float* vC = buf_->plane(kVC, k, K) + off;
      for (int x = 0; x < width_; ++x) {
        w[x] = k == 0 ? 1.0f : 0.0f;
        my[x] = k == 0 ? Y[x] : 0.0f;
        mu[x] = k == 0 ? U[x] : 0.0f;
        mv[x] = k == 0 ? V[x] : 0.0f;
        vY[x] = vy;
        vC[x] = vc;
      }
      if (has_depth_) {
        float* md = buf_->plane(kMD, k, K) + off;
        float* vD = buf_->plane(kVD, k, K) + off;
        float* fd = buf_->plane(kFD, k, K) + off;
        for (int x = 0; x < width_; ++x) {
          const bool valid = k == 0 && valid_depth(D[x]);
          md[x] = valid ? D[x] : 0.0f;
          vD[x] = vd;
          fd[x] = valid ? 1.0f : 0.0f;
        }
      }
    }
  }
}

Status YuvdBackground::set_background_depth(const cv::Mat& mask, const cv::Mat& depth) {
  if (frames_ == 0 || !has_depth_)
    return bad_input("", 0, "depth", "the model has not learnt a frame with depth yet");
  if (mask.type() != CV_8UC1 || mask.cols != width_ || mask.rows != height_)
    return bad_input("", 0, "mask", "expected a CV_8UC1 mask of the model's size, got " + describe(mask));
  if (depth.type() != CV_32FC1 || depth.cols != width_ || depth.rows != height_)
    return bad_input("", 0, "depth", "expected a CV_32FC1 depth image of the model's size, got " + describe(depth));
  const int K = params_.num_gaussians;
  const float vd = params_.init_sigma_depth * params_.init_sigma_depth;
  float* md = buf_->plane(kMD, 0, K);
  float* vD = buf_->plane(kVD, 0, K);
  float* fd = buf_->plane(kFD, 0, K);
  for (int y = 0; y < height_; ++y) {
    const uint8_t* m = mask.ptr<uint8_t>(y);
    const float* d = depth.ptr<float>(y);
    const std::size_t off = static_cast<std::size_t>(y) * stride_;
    for (int x = 0; x < width_; ++x) {
      if (!m[x] || !valid_depth(d[x])) continue;
      md[off + x] = d[x];
      vD[off + x] = vd;
      fd[off + x] = 1.0f;
    }
  }
  return Status::Ok();
}

void YuvdBackground::learn(const cv::Mat& depth, const cv::Mat& measured) {
  const YuvdBackgroundParams& p = params_;
  const int K = p.num_gaussians;
  Consts c{};
  c.T = p.match_threshold;
  c.T_agree = p.match_threshold * p.depth_agree_factor;
  c.dvf = p.depth_valid_fraction;
  c.ymin = p.min_chroma_luminance;
  c.rho = p.activity_rate;
  c.act_thr = p.activity_threshold;
  float a = p.learning_rate;
  if (frames_ < p.bootstrap_frames) a = std::max(a, 1.0f / static_cast<float>(frames_ + 1));
  c.a_hi = a;
  c.a_lo = a / p.activity_divisor;
  c.bg_w = p.background_weight;
  c.init_w = p.init_weight;
  c.vy_init = p.init_sigma_y * p.init_sigma_y;
  c.vy_min = p.min_sigma_y * p.min_sigma_y;
  c.vy_max = p.max_sigma_y * p.max_sigma_y;
  c.vc_init = p.init_sigma_c * p.init_sigma_c;
  c.vc_min = p.min_sigma_c * p.min_sigma_c;
  c.vc_max = p.max_sigma_c * p.max_sigma_c;
  c.vd_init = p.init_sigma_depth * p.init_sigma_depth;
  c.sd_min = p.min_sigma_depth;
  c.sd_rel = p.min_sigma_depth_rel;
  c.vd_max = p.max_sigma_depth * p.max_sigma_depth;
  c.block = p.nearer_blocks_replacement;

  const RowKernel kernel =
      select_kernel(K, has_depth_, cpu_has_avx2() && !force_portable_flag());
  RowArgs r{};
  r.width = width_;
  const int fields = has_depth_ ? kAllFields : kColourFields;
  for (int y = 0; y < height_; ++y) {
    r.Y = planes_[0].ptr<uint8_t>(y);
    r.U = planes_[1].ptr<uint8_t>(y);
    r.V = planes_[2].ptr<uint8_t>(y);
    r.PY = prev_y_.ptr<uint8_t>(y);
    r.D = depth.empty() ? buf_->zero_depth.get() : depth.ptr<float>(y);
    r.M = depth.empty() || measured.empty() ? nullptr : measured.ptr<uint8_t>(y);
    const std::size_t off = static_cast<std::size_t>(y) * stride_;
    for (int f = 0; f < fields; ++f)
      for (int k = 0; k < K; ++k) r.p[f][k] = buf_->plane(f, k, K) + off;
    r.act = buf_->activity.get() + off;
    r.mask = raw_mask_.ptr<uint8_t>(y);
    kernel(c, r);
  }
}

void YuvdBackground::clean_up(cv::Mat& fg_mask) {
  const cv::Mat* src = &raw_mask_;
  if (params_.open_radius > 0) {
    cv::morphologyEx(*src, fg_mask, cv::MORPH_OPEN, open_kernel_);
    src = &fg_mask;
  }
  if (params_.close_radius > 0) {
    cv::morphologyEx(*src, morph_tmp_, cv::MORPH_CLOSE, close_kernel_);
    cv::swap(morph_tmp_, fg_mask);
    src = &fg_mask;
  }
  if (src != &fg_mask) raw_mask_.copyTo(fg_mask);
  if (params_.min_component_area > 0) {
    cv::Mat labels, stats, centroids;
    const int n = cv::connectedComponentsWithStats(fg_mask, labels, stats, centroids, 8, CV_32S);
    std::vector<uint8_t> keep(static_cast<std::size_t>(n), 0);
    bool any_removed = false;
    for (int i = 1; i < n; ++i) {
      keep[i] = stats.at<int>(i, cv::CC_STAT_AREA) >= params_.min_component_area ? 255 : 0;
      any_removed |= keep[i] == 0;
    }
    if (any_removed) {
      for (int y = 0; y < fg_mask.rows; ++y) {
        const int* l = labels.ptr<int>(y);
        uint8_t* m = fg_mask.ptr<uint8_t>(y);
        for (int x = 0; x < fg_mask.cols; ++x) m[x] = keep[l[x]];
      }
    }
  }
}

Status YuvdBackground::check_input(const cv::Mat& bgr, const cv::Mat& depth) const {
  if (bgr.empty()) return bad_input("", 0, "frame", "empty frame");
  if (bgr.type() != CV_8UC3)
    return bad_input("", 0, "frame", "expected a BGR CV_8UC3 image, got " + describe(bgr));
  if (bgr.dims != 2) return bad_input("", 0, "frame", "expected a 2-D image");
  if (!depth.empty()) {
    if (depth.type() != CV_32FC1)
      return bad_input("", 0, "depth",
                       "expected a CV_32FC1 depth image in metres, got " + describe(depth));
    if (depth.size() != bgr.size())
      return bad_input("", 0, "depth",
                       "depth is " + describe(depth) + " but the frame is " + describe(bgr));
  }
  if (frames_ > 0 && (bgr.cols != width_ || bgr.rows != height_))
    return bad_input("", 0, "frame",
                     "frame size changed from " + std::to_string(width_) + "x" +
                         std::to_string(height_) + " to " + std::to_string(bgr.cols) + "x" +
                         std::to_string(bgr.rows) + " (reset() the model first)");
  return Status::Ok();
}

Status YuvdBackground::apply(const cv::Mat& bgr, const cv::Mat& depth, cv::Mat& fg_mask) {
  return apply(bgr, depth, cv::Mat(), fg_mask);
}

Status YuvdBackground::apply(const cv::Mat& bgr, const cv::Mat& depth, const cv::Mat& measured,
                             cv::Mat& fg_mask) {
  if (Status s = check_input(bgr, depth); !s) return s;
  if (!measured.empty() && (measured.type() != CV_8UC1 || measured.size() != bgr.size()))
    return bad_input("", 0, "depth_measured",
                     "expected a CV_8UC1 mask of the frame's size, got " + describe(measured));
  if (&fg_mask == &raw_mask_)
    return bad_input("", 0, "fg_mask", "must not be the model's own raw mask");

  cv::cvtColor(bgr, yuv_, cv::COLOR_BGR2YUV);
  cv::swap(planes_[0], prev_y_);  // last frame's Y plane
  cv::split(yuv_, planes_);
  raw_mask_.create(bgr.rows, bgr.cols, CV_8UC1);
  if (frames_ == 0) {
    allocate(bgr.cols, bgr.rows);
    if (!depth.empty()) add_depth_planes();
    if (!depth.empty() && !measured.empty()) {
      // Unmeasured depth on the first frame: no statistics there (as for an invalid depth).
      cv::Mat d = depth.clone();
      d.setTo(0.0f, measured == 0);
      first_frame(d);
    } else {
      first_frame(depth);
    }
    raw_mask_.setTo(0);
  } else {
    if (!depth.empty() && !has_depth_) add_depth_planes();
    learn(depth, measured);
  }
  ++frames_;
  clean_up(fg_mask);
  return Status::Ok();
}

Status YuvdBackground::colour_changes(const cv::Mat& bgr, cv::Mat& changed) const {
  if (Status s = check_input(bgr, cv::Mat()); !s) return s;
  changed.create(bgr.rows, bgr.cols, CV_8UC1);
  if (frames_ == 0) {
    changed.setTo(255);
    return Status::Ok();
  }
  const YuvdBackgroundParams& p = params_;
  const int K = p.num_gaussians;
  const float T = p.match_threshold, ymin = p.min_chroma_luminance, bg_w = p.background_weight;
  cv::Mat yuv;
  cv::cvtColor(bgr, yuv, cv::COLOR_BGR2YUV);
  for (int y = 0; y < height_; ++y) {
    const uint8_t* px = yuv.ptr<uint8_t>(y);
    uint8_t* out = changed.ptr<uint8_t>(y);
    const std::size_t off = static_cast<std::size_t>(y) * stride_;
    for (int x = 0; x < width_; ++x) {
      const float Y = px[3 * x], U = px[3 * x + 1], V = px[3 * x + 2];
      uint8_t differs = 255;
      float cum = 0.0f;
      for (int k = 0; k < K && cum < bg_w; ++k) {
        const std::size_t i = off + x;
        const float w = buf_->plane(kW, k, K)[i];
        cum += w;
        if (!(w > 0.0f)) continue;
        const float dy = Y - buf_->plane(kMY, k, K)[i];
        if (!(dy * dy < T * buf_->plane(kVY, k, K)[i])) continue;
        const float my = buf_->plane(kMY, k, K)[i];
        if (Y >= ymin && my >= ymin) {
          const float du = U - buf_->plane(kMU, k, K)[i], dv = V - buf_->plane(kMV, k, K)[i];
          if (!(du * du + dv * dv < T * buf_->plane(kVC, k, K)[i])) continue;
        }
        differs = 0;
        break;
      }
      out[x] = differs;
    }
  }
  return Status::Ok();
}

Result<YuvdGaussian> YuvdBackground::gaussian(int x, int y, int k) const {
  if (frames_ == 0) return bad_input("", 0, "gaussian", "the model has not seen a frame yet");
  if (x < 0 || y < 0 || x >= width_ || y >= height_)
    return bad_input("", 0, "gaussian",
                     "pixel (" + std::to_string(x) + ", " + std::to_string(y) +
                         ") outside the " + std::to_string(width_) + "x" +
                         std::to_string(height_) + " model");
  const int K = params_.num_gaussians;
  if (k < 0 || k >= K)
    return bad_input("", 0, "gaussian",
                     "Gaussian " + std::to_string(k) + " outside 0.." + std::to_string(K - 1));
  const std::size_t i = static_cast<std::size_t>(y) * stride_ + x;
  auto at = [&](int f, int j) { return buf_->plane(f, j, K)[i]; };
  YuvdGaussian g;
  g.weight = at(kW, k);
  g.mean_y = at(kMY, k);
  g.mean_u = at(kMU, k);
  g.mean_v = at(kMV, k);
  g.sigma_y = std::sqrt(at(kVY, k));
  g.sigma_c = std::sqrt(at(kVC, k));
  if (has_depth_) {
    g.mean_depth = at(kMD, k);
    g.sigma_depth = std::sqrt(at(kVD, k));
    g.depth_valid_fraction = at(kFD, k);
  }
  float cum = 0;
  for (int j = 0; j < k; ++j) cum += at(kW, j);
  g.background = cum < params_.background_weight && g.weight > 0.0f;
  return g;
}

float YuvdBackground::activity(int x, int y) const {
  if (frames_ == 0 || x < 0 || y < 0 || x >= width_ || y >= height_) return 0.0f;
  return buf_->activity.get()[static_cast<std::size_t>(y) * stride_ + x];
}

cv::Mat YuvdBackground::background_image() const {
  if (frames_ == 0) return {};
  const int K = params_.num_gaussians;
  cv::Mat yuv(height_, width_, CV_8UC3);
  for (int y = 0; y < height_; ++y) {
    const std::size_t off = static_cast<std::size_t>(y) * stride_;
    const float* my = buf_->plane(kMY, 0, K) + off;
    const float* mu = buf_->plane(kMU, 0, K) + off;
    const float* mv = buf_->plane(kMV, 0, K) + off;
    uint8_t* d = yuv.ptr<uint8_t>(y);
    for (int x = 0; x < width_; ++x) {
      d[3 * x] = cv::saturate_cast<uint8_t>(my[x]);
      d[3 * x + 1] = cv::saturate_cast<uint8_t>(mu[x]);
      d[3 * x + 2] = cv::saturate_cast<uint8_t>(mv[x]);
    }
  }
  cv::Mat bgr;
  cv::cvtColor(yuv, bgr, cv::COLOR_YUV2BGR);
  return bgr;
}

}  // namespace vigil::vision
