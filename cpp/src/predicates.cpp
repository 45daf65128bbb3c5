// Slow paths of the adaptive predicates (see faultmesh/predicates.hpp).
//
// The expansion arithmetic follows Shewchuk (1997): a number is represented
// exactly as a sum of doubles of increasing magnitude whose bits do not
// overlap; sums and products of such expansions are exact. The stages:
//   orient2d: A (filter, inline) -> B (exact products of rounded differences)
//             -> C (first-order tail correction) -> exact.
//   incircle: A (filter, inline) -> B (exact products of rounded differences)
//             -> exact on the raw coordinates when a difference was inexact.
//   orient3d: A (filter, inline) -> B (exact products of rounded differences)
//             -> C (first-order tail correction) -> exact on the differences
//             carried as two-term expansions.
#include <faultmesh/predicates.hpp>

#include <charconv>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace faultmesh {
namespace detail {
namespace {

constexpr double kSplitter = 134217729.0;  // 2^27 + 1
constexpr double kResultErrBound = (3.0 + 8.0 * kEpsilon) * kEpsilon;
constexpr double kCcwErrBoundB = (2.0 + 12.0 * kEpsilon) * kEpsilon;
constexpr double kCcwErrBoundC = (9.0 + 64.0 * kEpsilon) * kEpsilon * kEpsilon;
constexpr double kIccErrBoundB = (4.0 + 48.0 * kEpsilon) * kEpsilon;

// x + y == a + b exactly, given |a| >= |b| (or a == 0).
inline void fast_two_sum(double a, double b, double& x, double& y) {
    x = a + b;
    const double bvirt = x - a;
    y = b - bvirt;
}
inline void two_sum(double a, double b, double& x, double& y) {
    x = a + b;
    const double bvirt = x - a;
    const double avirt = x - bvirt;
    const double bround = b - bvirt;
    const double around = a - avirt;
    y = around + bround;
}
inline void two_diff_tail(double a, double b, double x, double& y) {
    const double bvirt = a - x;
    const double avirt = x + bvirt;
    const double bround = bvirt - b;
    const double around = a - avirt;
    y = around + bround;
}
inline void two_diff(double a, double b, double& x, double& y) {
    x = a - b;
    two_diff_tail(a, b, x, y);
}
inline void split(double a, double& hi, double& lo) {
    const double c = kSplitter * a;
    const double abig = c - a;
    hi = c - abig;
    lo = a - hi;
}
inline void two_product_presplit(double a, double b, double bhi, double blo, double& x, double& y) {
    x = a * b;
    double ahi, alo;
    split(a, ahi, alo);
    const double err1 = x - (ahi * bhi);
    const double err2 = err1 - (alo * bhi);
    const double err3 = err2 - (ahi * blo);
    y = (alo * blo) - err3;
}
inline void two_product(double a, double b, double& x, double& y) {
    double bhi, blo;
    split(b, bhi, blo);
    two_product_presplit(a, b, bhi, blo, x, y);
}
// (a1 + a0) - b == x2 + x1 + x0
inline void two_one_diff(double a1, double a0, double b, double& x2, double& x1, double& x0) {
    double i;
    two_diff(a0, b, i, x0);
    two_sum(a1, i, x2, x1);
}
// (a1 + a0) - (b1 + b0) == x[3] + x[2] + x[1] + x[0]
inline void two_two_diff(double a1, double a0, double b1, double b0, double* x) {
    double j, z;
    two_one_diff(a1, a0, b0, j, z, x[0]);
    two_one_diff(j, z, b1, x[3], x[2], x[1]);
}
// a*d - b*c as a 4-component expansion, exactly.
inline void cross_expansion(double a, double d, double b, double c, double* x) {
    double p1, p0, q1, q0;
    two_product(a, d, p1, p0);
    two_product(b, c, q1, q0);
    two_two_diff(p1, p0, q1, q0, x);
}

// h = e + f, zero components removed; returns the length of h.
int expansion_sum(int elen, const double* e, int flen, const double* f, double* h) {
    double enow = e[0], fnow = f[0];
    int ei = 0, fi = 0, hi = 0;
    double q, qnew, hh;
    auto next_e = [&]() { ++ei; enow = ei < elen ? e[ei] : 0.0; };
    auto next_f = [&]() { ++fi; fnow = fi < flen ? f[fi] : 0.0; };
    if ((fnow > enow) == (fnow > -enow)) { q = enow; next_e(); }
    else { q = fnow; next_f(); }
    if (ei < elen && fi < flen) {
        if ((fnow > enow) == (fnow > -enow)) { fast_two_sum(enow, q, qnew, hh); next_e(); }
        else { fast_two_sum(fnow, q, qnew, hh); next_f(); }
        q = qnew;
        if (hh != 0.0) h[hi++] = hh;
        while (ei < elen && fi < flen) {
            if ((fnow > enow) == (fnow > -enow)) { two_sum(q, enow, qnew, hh); next_e(); }
            else { two_sum(q, fnow, qnew, hh); next_f(); }
            q = qnew;
            if (hh != 0.0) h[hi++] = hh;
        }
    }
    while (ei < elen) {
        two_sum(q, enow, qnew, hh);
        next_e();
        q = qnew;
        if (hh != 0.0) h[hi++] = hh;
    }
    while (fi < flen) {
        two_sum(q, fnow, qnew, hh);
        next_f();
        q = qnew;
        if (hh != 0.0) h[hi++] = hh;
    }
    if (q != 0.0 || hi == 0) h[hi++] = q;
    return hi;
}

// h = b * e, zero components removed; returns the length of h.
int scale_expansion(int elen, const double* e, double b, double* h) {
    double bhi, blo;
    split(b, bhi, blo);
    double q, hh, p1, p0, sum;
    two_product_presplit(e[0], b, bhi, blo, q, hh);
    int hi = 0;
    if (hh != 0.0) h[hi++] = hh;
    for (int i = 1; i < elen; ++i) {
        two_product_presplit(e[i], b, bhi, blo, p1, p0);
        two_sum(q, p0, sum, hh);
        if (hh != 0.0) h[hi++] = hh;
        fast_two_sum(p1, sum, q, hh);
        if (hh != 0.0) h[hi++] = hh;
    }
    if (q != 0.0 || hi == 0) h[hi++] = q;
    return hi;
}

double estimate(int elen, const double* e) {
    double q = e[0];
    for (int i = 1; i < elen; ++i) q += e[i];
    return q;
}

// det = lift-weighted 2x2 minor: (x^2 + y^2) * m, m an expansion.
int lifted_term(int mlen, const double* m, double x, double y, double* out) {
    double t24x[24], t48x[48], t24y[24], t48y[48];
    const int xl = scale_expansion(mlen, m, x, t24x);
    const int xxl = scale_expansion(xl, t24x, x, t48x);
    const int yl = scale_expansion(mlen, m, y, t24y);
    const int yyl = scale_expansion(yl, t24y, y, t48y);
    return expansion_sum(xxl, t48x, yyl, t48y, out);
}

// Exact in-circle determinant on the raw coordinates (no rounded differences).
double incircle_exact(const double* pa, const double* pb, const double* pc, const double* pd) {
    double ab[4], bc[4], cd[4], da[4], ac[4], bd[4];
    cross_expansion(pa[0], pb[1], pb[0], pa[1], ab);
    cross_expansion(pb[0], pc[1], pc[0], pb[1], bc);
    cross_expansion(pc[0], pd[1], pd[0], pc[1], cd);
    cross_expansion(pd[0], pa[1], pa[0], pd[1], da);
    cross_expansion(pa[0], pc[1], pc[0], pa[1], ac);
    cross_expansion(pb[0], pd[1], pd[0], pb[1], bd);

    double temp8[8], cda[12], dab[12], abc[12], bcd[12];
    int tl = expansion_sum(4, cd, 4, da, temp8);
    const int cdal = expansion_sum(tl, temp8, 4, ac, cda);
    tl = expansion_sum(4, da, 4, ab, temp8);
    const int dabl = expansion_sum(tl, temp8, 4, bd, dab);
    for (int i = 0; i < 4; ++i) {
        bd[i] = -bd[i];
        ac[i] = -ac[i];
    }
    tl = expansion_sum(4, ab, 4, bc, temp8);
    const int abcl = expansion_sum(tl, temp8, 4, ac, abc);
    tl = expansion_sum(4, bc, 4, cd, temp8);
    const int bcdl = expansion_sum(tl, temp8, 4, bd, bcd);

    double adet[96], bdet[96], cdet[96], ddet[96];
    const int al = lifted_term(bcdl, bcd, pa[0], pa[1], adet);
    int bl = lifted_term(cdal, cda, pb[0], pb[1], bdet);
    for (int i = 0; i < bl; ++i) bdet[i] = -bdet[i];
    const int cl = lifted_term(dabl, dab, pc[0], pc[1], cdet);
    int dl = lifted_term(abcl, abc, pd[0], pd[1], ddet);
    for (int i = 0; i < dl; ++i) ddet[i] = -ddet[i];

    double abdet[192], cddet[192], deter[384];
    const int abl = expansion_sum(al, adet, bl, bdet, abdet);
    const int cdl = expansion_sum(cl, cdet, dl, ddet, cddet);
    const int n = expansion_sum(abl, abdet, cdl, cddet, deter);
    return deter[n - 1];
}


// ------------------------------------------------------------ exact integers
// The fallback for inputs whose products may underflow (see predicates.hpp).
// Every finite double is an integer multiple of 2^-1074, so X = x * 2^1074 is
// an integer (below 2^2098); the determinants are evaluated on these
// integers exactly (schoolbook arithmetic on 32-bit limbs: at most ~270 limbs
// for the in-circle determinant, microseconds, and only reached by tiny
// coordinates). Signed magnitude, little-endian limbs, no leading zero limb.
struct BigInt {
    bool neg = false;
    std::vector<std::uint32_t> mag;
};

void trim(std::vector<std::uint32_t>& m) {
    while (!m.empty() && m.back() == 0) m.pop_back();
}

int cmp_mag(const std::vector<std::uint32_t>& a, const std::vector<std::uint32_t>& b) {
    if (a.size() != b.size()) return a.size() < b.size() ? -1 : 1;
    for (std::size_t i = a.size(); i-- > 0;)
        if (a[i] != b[i]) return a[i] < b[i] ? -1 : 1;
    return 0;
}

std::vector<std::uint32_t> add_mag(const std::vector<std::uint32_t>& a, const std::vector<std::uint32_t>& b) {
    const std::vector<std::uint32_t>& l = a.size() >= b.size() ? a : b;
    const std::vector<std::uint32_t>& s = a.size() >= b.size() ? b : a;
    std::vector<std::uint32_t> r(l.size() + 1);
    std::uint64_t carry = 0;
    for (std::size_t i = 0; i < l.size(); ++i) {
        const std::uint64_t t = std::uint64_t{l[i]} + (i < s.size() ? s[i] : 0u) + carry;
        r[i] = static_cast<std::uint32_t>(t);
        carry = t >> 32;
    }
    r[l.size()] = static_cast<std::uint32_t>(carry);
    trim(r);
    return r;
}

// a - b for a >= b.
std::vector<std::uint32_t> sub_mag(const std::vector<std::uint32_t>& a, const std::vector<std::uint32_t>& b) {
    std::vector<std::uint32_t> r(a.size());
    std::int64_t borrow = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        std::int64_t t = std::int64_t{a[i]} - (i < b.size() ? b[i] : 0u) - borrow;
        borrow = t < 0;
        if (t < 0) t += std::int64_t{1} << 32;
        r[i] = static_cast<std::uint32_t>(t);
    }
    trim(r);
    return r;
}

BigInt add(const BigInt& a, const BigInt& b) {
    BigInt r;
    if (a.neg == b.neg) {
        r.mag = add_mag(a.mag, b.mag);
        r.neg = a.neg;
    } else if (cmp_mag(a.mag, b.mag) >= 0) {
        r.mag = sub_mag(a.mag, b.mag);
        r.neg = a.neg;
    } else {
        r.mag = sub_mag(b.mag, a.mag);
        r.neg = b.neg;
    }
    if (r.mag.empty()) r.neg = false;
    return r;
}

BigInt sub(const BigInt& a, BigInt b) {
    b.neg = !b.neg && !b.mag.empty();
    return add(a, b);
}

BigInt mul(const BigInt& a, const BigInt& b) {
    BigInt r;
    if (a.mag.empty() || b.mag.empty()) return r;
    r.mag.assign(a.mag.size() + b.mag.size(), 0);
    for (std::size_t i = 0; i < a.mag.size(); ++i) {
        std::uint64_t carry = 0;
        for (std::size_t j = 0; j < b.mag.size(); ++j) {
            const std::uint64_t t = std::uint64_t{a.mag[i]} * b.mag[j] + r.mag[i + j] + carry;
            r.mag[i + j] = static_cast<std::uint32_t>(t);
            carry = t >> 32;
        }
        r.mag[i + b.mag.size()] = static_cast<std::uint32_t>(carry);
    }
    trim(r.mag);
    r.neg = a.neg != b.neg;
    return r;
}

// x * 2^1074, exactly (x finite).
BigInt from_double(double x) {
    BigInt r;
    if (x == 0.0) return r;
    int e = 0;
    const double f = std::frexp(std::fabs(x), &e);  // |x| = f 2^e, f in [0.5, 1)
    std::uint64_t mant = static_cast<std::uint64_t>(std::ldexp(f, 53));
    int shift = e - 53 + 1074;
    if (shift < 0) {  // subnormal: the low bits of mant are zero
        mant >>= -shift;
        shift = 0;
    }
    r.neg = x < 0.0;
    const std::size_t limbs = static_cast<std::size_t>(shift) / 32;
    const unsigned bits = static_cast<unsigned>(shift) % 32;
    r.mag.assign(limbs + 3, 0);
    // mant < 2^53 shifted by < 32 bits spans at most three limbs.
    const std::uint64_t lo = mant << bits;                         // low 64 bits
    const std::uint64_t hi = bits ? mant >> (64 - bits) : 0;       // the rest
    r.mag[limbs] = static_cast<std::uint32_t>(lo);
    r.mag[limbs + 1] = static_cast<std::uint32_t>(lo >> 32);
    r.mag[limbs + 2] = static_cast<std::uint32_t>(hi);
    trim(r.mag);
    return r;
}

// The value b * 2^-scale rounded to a double (approximately: the top 64 bits),
// never 0 for b != 0 (+-denorm_min then), +-inf beyond the double range.
double to_double(const BigInt& b, int scale) {
    if (b.mag.empty()) return 0.0;
    const std::size_t n = b.mag.size();
    int top_bits = 32;
    while (!(b.mag[n - 1] >> (top_bits - 1))) --top_bits;
    const long long length = 32LL * static_cast<long long>(n - 1) + top_bits;  // bit length
    // The top (up to) 64 bits.
    std::uint64_t top = 0;
    const long long drop = length > 64 ? length - 64 : 0;
    for (long long k = length - 1; k >= drop; --k)
        top = (top << 1) | ((b.mag[static_cast<std::size_t>(k / 32)] >> (k % 32)) & 1u);
    double v = std::ldexp(static_cast<double>(top), static_cast<int>(drop) - scale);
    if (v == 0.0) v = std::numeric_limits<double>::denorm_min();
    return b.neg ? -v : v;
}

double orient2d_exact_integer(const double* pa, const double* pb, const double* pc) {
    const BigInt cx = from_double(pc[0]), cy = from_double(pc[1]);
    const BigInt acx = sub(from_double(pa[0]), cx), bcy = sub(from_double(pb[1]), cy);
    const BigInt acy = sub(from_double(pa[1]), cy), bcx = sub(from_double(pb[0]), cx);
    return to_double(sub(mul(acx, bcy), mul(acy, bcx)), 2 * 1074);
}

double incircle_exact_integer(const double* pa, const double* pb, const double* pc, const double* pd) {
    const BigInt dx = from_double(pd[0]), dy = from_double(pd[1]);
    const BigInt adx = sub(from_double(pa[0]), dx), ady = sub(from_double(pa[1]), dy);
    const BigInt bdx = sub(from_double(pb[0]), dx), bdy = sub(from_double(pb[1]), dy);
    const BigInt cdx = sub(from_double(pc[0]), dx), cdy = sub(from_double(pc[1]), dy);
    const BigInt alift = add(mul(adx, adx), mul(ady, ady));
    const BigInt blift = add(mul(bdx, bdx), mul(bdy, bdy));
    const BigInt clift = add(mul(cdx, cdx), mul(cdy, cdy));
    const BigInt det = add(add(mul(alift, sub(mul(bdx, cdy), mul(cdx, bdy))),
                               mul(blift, sub(mul(cdx, ady), mul(adx, cdy)))),
                           mul(clift, sub(mul(adx, bdy), mul(bdx, ady))));
    return to_double(det, 4 * 1074);
}

// A non-zero coordinate below `limit` in magnitude: products in the exact
// stages may then be subnormal (see predicates.hpp). Branch-free: called on
// every exactly-zero in-circle result (cocircular grid points).
inline bool tiny(double v, double limit) { return (v != 0.0) & (std::fabs(v) < limit); }
inline bool has_tiny(double limit, const double* a, const double* b, const double* c) {
    return tiny(a[0], limit) | tiny(a[1], limit) | tiny(b[0], limit) | tiny(b[1], limit) | tiny(c[0], limit) |
           tiny(c[1], limit);
}
inline bool has_tiny(double limit, const double* a, const double* b, const double* c, const double* d) {
    return has_tiny(limit, a, b, c) | tiny(d[0], limit) | tiny(d[1], limit);
}
constexpr double kTinyOrient = 0x1p-400;    // 4 differences' quanta >= 2^-452: products >= 2^-904
constexpr double kTinyIncircle = 0x1p-200;  // degree 4: products >= 2^-1008 > DBL_MIN = 2^-1022
// An exact-stage result at least this large cannot have its sign changed by
// the (at most a few hundred) underflows of 2^-1074 each.
constexpr double kCertified = 0x1p-1000;

bool finite_points(std::initializer_list<const double*> pts) {
    for (const double* p : pts)
        if (!std::isfinite(p[0]) || !std::isfinite(p[1])) return false;
    return true;
}

double certify_orient2d(double r, const double* pa, const double* pb, const double* pc) {
    if (r >= kCertified || -r >= kCertified || !has_tiny(kTinyOrient, pa, pb, pc)) return r;
    return orient2d_exact_integer(pa, pb, pc);
}

double certify_incircle(double r, const double* pa, const double* pb, const double* pc, const double* pd) {
    if (r >= kCertified || -r >= kCertified || !has_tiny(kTinyIncircle, pa, pb, pc, pd)) return r;
    return incircle_exact_integer(pa, pb, pc, pd);
}

// ---- orient3d (kept in its own block) -------------------------------------
constexpr double kO3dErrBoundB = (3.0 + 28.0 * kEpsilon) * kEpsilon;
constexpr double kO3dErrBoundC = (26.0 + 288.0 * kEpsilon) * kEpsilon * kEpsilon;

// a - b exactly, as an expansion of one or two components; returns the length.
inline int difference_expansion(double a, double b, double* h) {
    double x, y;
    two_diff(a, b, x, y);
    if (y == 0.0) {
        h[0] = x;
        return 1;
    }
    h[0] = y;
    h[1] = x;
    return 2;
}

// h = e * f for an expansion e of at most 16 components and f of one or two
// (h holds up to 4 * elen components); returns the length of h.
int product_by_short(int elen, const double* e, int flen, const double* f, double* h) {
    double t0[32], t1[32];
    const int l0 = scale_expansion(elen, e, f[0], t0);
    if (flen == 1) {
        for (int i = 0; i < l0; ++i) h[i] = t0[i];
        return l0;
    }
    const int l1 = scale_expansion(elen, e, f[1], t1);
    return expansion_sum(l0, t0, l1, t1, h);
}

// p * q - r * s for expansions of one or two components (up to 16 out).
int two_by_two_minor(int pl, const double* p, int ql, const double* q, int rl, const double* r, int sl,
                     const double* s, double* h) {
    double pq[8], rs[8];
    const int a = product_by_short(pl, p, ql, q, pq);
    const int b = product_by_short(rl, r, sl, s, rs);
    for (int i = 0; i < b; ++i) rs[i] = -rs[i];
    return expansion_sum(a, pq, b, rs, h);
}

// The exact orient3d determinant: every coordinate difference is carried
// exactly (two components), so no rounding enters anywhere.
double orient3d_exact(const double* pa, const double* pb, const double* pc, const double* pd) {
    double adx[2], bdx[2], cdx[2], ady[2], bdy[2], cdy[2], adz[2], bdz[2], cdz[2];
    const int adxl = difference_expansion(pa[0], pd[0], adx);
    const int bdxl = difference_expansion(pb[0], pd[0], bdx);
    const int cdxl = difference_expansion(pc[0], pd[0], cdx);
    const int adyl = difference_expansion(pa[1], pd[1], ady);
    const int bdyl = difference_expansion(pb[1], pd[1], bdy);
    const int cdyl = difference_expansion(pc[1], pd[1], cdy);
    const int adzl = difference_expansion(pa[2], pd[2], adz);
    const int bdzl = difference_expansion(pb[2], pd[2], bdz);
    const int cdzl = difference_expansion(pc[2], pd[2], cdz);

    double bc[16], ca[16], ab[16];
    const int bcl = two_by_two_minor(bdxl, bdx, cdyl, cdy, cdxl, cdx, bdyl, bdy, bc);
    const int cal = two_by_two_minor(cdxl, cdx, adyl, ady, adxl, adx, cdyl, cdy, ca);
    const int abl = two_by_two_minor(adxl, adx, bdyl, bdy, bdxl, bdx, adyl, ady, ab);
    double adet[64], bdet[64], cdet[64];
    const int al = product_by_short(bcl, bc, adzl, adz, adet);
    const int bl = product_by_short(cal, ca, bdzl, bdz, bdet);
    const int cl = product_by_short(abl, ab, cdzl, cdz, cdet);
    double abdet[128], fin[192];
    const int abdl = expansion_sum(al, adet, bl, bdet, abdet);
    const int n = expansion_sum(abdl, abdet, cl, cdet, fin);
    return fin[n - 1];
}

// orient3d on the integers X = x * 2^1074 (see the exact-integer block above).
double orient3d_exact_integer(const double* pa, const double* pb, const double* pc, const double* pd) {
    const BigInt dx = from_double(pd[0]), dy = from_double(pd[1]), dz = from_double(pd[2]);
    const BigInt adx = sub(from_double(pa[0]), dx), ady = sub(from_double(pa[1]), dy), adz = sub(from_double(pa[2]), dz);
    const BigInt bdx = sub(from_double(pb[0]), dx), bdy = sub(from_double(pb[1]), dy), bdz = sub(from_double(pb[2]), dz);
    const BigInt cdx = sub(from_double(pc[0]), dx), cdy = sub(from_double(pc[1]), dy), cdz = sub(from_double(pc[2]), dz);
    const BigInt det = add(add(mul(adz, sub(mul(bdx, cdy), mul(cdx, bdy))), mul(bdz, sub(mul(cdx, ady), mul(adx, cdy)))),
                           mul(cdz, sub(mul(adx, bdy), mul(bdx, ady))));
    return to_double(det, 3 * 1074);
}

// Degree 3: with every non-zero coordinate >= 2^-280 the differences are
// multiples of 2^-332 and every non-zero product of three in the exact stages
// is >= 2^-996 > DBL_MIN = 2^-1022 (no underflow).
constexpr double kTinyOrient3d = 0x1p-280;
inline bool has_tiny3(double limit, const double* a, const double* b, const double* c, const double* d) {
    bool t = false;
    for (int k = 0; k < 3; ++k)
        t |= tiny(a[k], limit) | tiny(b[k], limit) | tiny(c[k], limit) | tiny(d[k], limit);
    return t;
}

double certify_orient3d(double r, const double* pa, const double* pb, const double* pc, const double* pd) {
    if (r >= kCertified || -r >= kCertified || !has_tiny3(kTinyOrient3d, pa, pb, pc, pd)) return r;
    return orient3d_exact_integer(pa, pb, pc, pd);
}
// ---------------------------------------------------------------------------

}  // namespace

double orient2d_adapt(const double* pa, const double* pb, const double* pc, double detsum) {
    const double acx = pa[0] - pc[0], bcx = pb[0] - pc[0];
    const double acy = pa[1] - pc[1], bcy = pb[1] - pc[1];

    double b[4];
    cross_expansion(acx, bcy, acy, bcx, b);
    double det = estimate(4, b);
    double errbound = kCcwErrBoundB * detsum;
    if (det >= errbound || -det >= errbound) return det;

    double acxtail, bcxtail, acytail, bcytail;
    two_diff_tail(pa[0], pc[0], acx, acxtail);
    two_diff_tail(pb[0], pc[0], bcx, bcxtail);
    two_diff_tail(pa[1], pc[1], acy, acytail);
    two_diff_tail(pb[1], pc[1], bcy, bcytail);
    if (acxtail == 0.0 && acytail == 0.0 && bcxtail == 0.0 && bcytail == 0.0)
        return certify_orient2d(det, pa, pb, pc);

    errbound = kCcwErrBoundC * detsum + kResultErrBound * std::fabs(det);
    det += (acx * bcytail + bcy * acxtail) - (acy * bcxtail + bcx * acytail);
    if (det >= errbound || -det >= errbound) return det;

    double u[4], c1[8], c2[12], d[16];
    cross_expansion(acxtail, bcy, acytail, bcx, u);
    const int c1l = expansion_sum(4, b, 4, u, c1);
    cross_expansion(acx, bcytail, acy, bcxtail, u);
    const int c2l = expansion_sum(c1l, c1, 4, u, c2);
    cross_expansion(acxtail, bcytail, acytail, bcxtail, u);
    const int dl = expansion_sum(c2l, c2, 4, u, d);
    return certify_orient2d(d[dl - 1], pa, pb, pc);
}

double incircle_adapt(const double* pa, const double* pb, const double* pc, const double* pd,
                      double permanent) {
    const double adx = pa[0] - pd[0], bdx = pb[0] - pd[0], cdx = pc[0] - pd[0];
    const double ady = pa[1] - pd[1], bdy = pb[1] - pd[1], cdy = pc[1] - pd[1];

    double bc[4], ca[4], ab[4];
    cross_expansion(bdx, cdy, cdx, bdy, bc);
    cross_expansion(cdx, ady, adx, cdy, ca);
    cross_expansion(adx, bdy, bdx, ady, ab);

    double adet[32], bdet[32], cdet[32];
    const int al = lifted_term(4, bc, adx, ady, adet);
    const int bl = lifted_term(4, ca, bdx, bdy, bdet);
    const int cl = lifted_term(4, ab, cdx, cdy, cdet);
    double abdet[64], fin[96];
    const int abl = expansion_sum(al, adet, bl, bdet, abdet);
    const int fl = expansion_sum(abl, abdet, cl, cdet, fin);

    const double det = estimate(fl, fin);
    const double errbound = kIccErrBoundB * permanent;
    if (det >= errbound || -det >= errbound) return det;

    double t;
    bool exact_differences = true;
    const double* pts[3] = {pa, pb, pc};
    const double dx[3] = {adx, bdx, cdx};
    const double dy[3] = {ady, bdy, cdy};
    for (int i = 0; i < 3; ++i) {
        two_diff_tail(pts[i][0], pd[0], dx[i], t);
        exact_differences = exact_differences && t == 0.0;
        two_diff_tail(pts[i][1], pd[1], dy[i], t);
        exact_differences = exact_differences && t == 0.0;
    }
    // With exact differences `fin` is the exact determinant; its most
    // significant component carries the sign.
    if (exact_differences) return certify_incircle(fin[fl - 1], pa, pb, pc, pd);
    return certify_incircle(incircle_exact(pa, pb, pc, pd), pa, pb, pc, pd);
}

double orient2d_small(const double* pa, const double* pb, const double* pc) {
    const double detleft = (pa[0] - pc[0]) * (pb[1] - pc[1]);
    const double detright = (pa[1] - pc[1]) * (pb[0] - pc[0]);
    const double det = detleft - detright;
    if (!finite_points({pa, pb, pc})) return det;  // NaN / inf in, NaN / inf out
    if (has_tiny(kTinyOrient, pa, pb, pc)) return orient2d_exact_integer(pa, pb, pc);
    // No product can have underflowed: the products are exact zeros or normal
    // doubles, and Shewchuk's filter applies as it stands.
    double detsum;
    if (detleft > 0.0) {
        if (detright <= 0.0) return det;
        detsum = detleft + detright;
    } else if (detleft < 0.0) {
        if (detright >= 0.0) return det;
        detsum = -detleft - detright;
    } else {
        return det;
    }
    const double errbound = kCcwErrBoundA * detsum;
    if (det >= errbound || -det >= errbound) return det;
    return orient2d_adapt(pa, pb, pc, detsum);
}

double incircle_small(const double* pa, const double* pb, const double* pc, const double* pd) {
    if (!finite_points({pa, pb, pc, pd})) {
        const double adx = pa[0] - pd[0], bdx = pb[0] - pd[0], cdx = pc[0] - pd[0];
        const double ady = pa[1] - pd[1], bdy = pb[1] - pd[1], cdy = pc[1] - pd[1];
        return (adx * adx + ady * ady) * (bdx * cdy - cdx * bdy) +
               (bdx * bdx + bdy * bdy) * (cdx * ady - adx * cdy) +
               (cdx * cdx + cdy * cdy) * (adx * bdy - bdx * ady);
    }
    if (has_tiny(kTinyIncircle, pa, pb, pc, pd)) return incircle_exact_integer(pa, pb, pc, pd);
    // No underflow possible: the permanent is 0 (then so is the determinant,
    // every product having a zero factor) or a normal double, and the adaptive
    // stages are exact.
    const double adx = pa[0] - pd[0], bdx = pb[0] - pd[0], cdx = pc[0] - pd[0];
    const double ady = pa[1] - pd[1], bdy = pb[1] - pd[1], cdy = pc[1] - pd[1];
    const double bdxcdy = bdx * cdy, cdxbdy = cdx * bdy;
    const double cdxady = cdx * ady, adxcdy = adx * cdy;
    const double adxbdy = adx * bdy, bdxady = bdx * ady;
    const double alift = adx * adx + ady * ady, blift = bdx * bdx + bdy * bdy, clift = cdx * cdx + cdy * cdy;
    const double det = alift * (bdxcdy - cdxbdy) + blift * (cdxady - adxcdy) + clift * (adxbdy - bdxady);
    const double permanent = (std::fabs(bdxcdy) + std::fabs(cdxbdy)) * alift +
                             (std::fabs(cdxady) + std::fabs(adxcdy)) * blift +
                             (std::fabs(adxbdy) + std::fabs(bdxady)) * clift;
    if (permanent == 0.0) return 0.0;
    const double errbound = kIccErrBoundA * permanent;
    if (det > errbound || -det > errbound) return det;
    return incircle_adapt(pa, pb, pc, pd, permanent);
}

double orient3d_adapt(const double* pa, const double* pb, const double* pc, const double* pd,
                      double permanent) {
    const double adx = pa[0] - pd[0], bdx = pb[0] - pd[0], cdx = pc[0] - pd[0];
    const double ady = pa[1] - pd[1], bdy = pb[1] - pd[1], cdy = pc[1] - pd[1];
    const double adz = pa[2] - pd[2], bdz = pb[2] - pd[2], cdz = pc[2] - pd[2];

    // Stage B: exact products of the rounded differences.
    double bc[4], ca[4], ab[4];
    cross_expansion(bdx, cdy, cdx, bdy, bc);
    cross_expansion(cdx, ady, adx, cdy, ca);
    cross_expansion(adx, bdy, bdx, ady, ab);
    double adet[8], bdet[8], cdet[8];
    const int al = scale_expansion(4, bc, adz, adet);
    const int bl = scale_expansion(4, ca, bdz, bdet);
    const int cl = scale_expansion(4, ab, cdz, cdet);
    double abdet[16], fin[24];
    const int abl = expansion_sum(al, adet, bl, bdet, abdet);
    const int fl = expansion_sum(abl, abdet, cl, cdet, fin);
    double det = estimate(fl, fin);
    double errbound = kO3dErrBoundB * permanent;
    if (det >= errbound || -det >= errbound) return det;

    double adxtail, bdxtail, cdxtail, adytail, bdytail, cdytail, adztail, bdztail, cdztail;
    two_diff_tail(pa[0], pd[0], adx, adxtail);
    two_diff_tail(pb[0], pd[0], bdx, bdxtail);
    two_diff_tail(pc[0], pd[0], cdx, cdxtail);
    two_diff_tail(pa[1], pd[1], ady, adytail);
    two_diff_tail(pb[1], pd[1], bdy, bdytail);
    two_diff_tail(pc[1], pd[1], cdy, cdytail);
    two_diff_tail(pa[2], pd[2], adz, adztail);
    two_diff_tail(pb[2], pd[2], bdz, bdztail);
    two_diff_tail(pc[2], pd[2], cdz, cdztail);
    // Exact differences: `fin` is the exact determinant.
    if (adxtail == 0.0 && bdxtail == 0.0 && cdxtail == 0.0 && adytail == 0.0 && bdytail == 0.0 &&
        cdytail == 0.0 && adztail == 0.0 && bdztail == 0.0 && cdztail == 0.0)
        return certify_orient3d(fin[fl - 1], pa, pb, pc, pd);

    // Stage C: first-order correction by the differences' rounding errors.
    errbound = kO3dErrBoundC * permanent + kResultErrBound * std::fabs(det);
    det += (adz * ((bdx * cdytail + cdy * bdxtail) - (bdy * cdxtail + cdx * bdytail)) +
            adztail * (bdx * cdy - bdy * cdx)) +
           (bdz * ((cdx * adytail + ady * cdxtail) - (cdy * adxtail + adx * cdytail)) +
            bdztail * (cdx * ady - cdy * adx)) +
           (cdz * ((adx * bdytail + bdy * adxtail) - (ady * bdxtail + bdx * adytail)) +
            cdztail * (adx * bdy - ady * bdx));
    if (det >= errbound || -det >= errbound) return det;
    return certify_orient3d(orient3d_exact(pa, pb, pc, pd), pa, pb, pc, pd);
}

double orient3d_small(const double* pa, const double* pb, const double* pc, const double* pd, double det,
                      double permanent) {
    bool finite = true;
    for (const double* p : {pa, pb, pc, pd}) finite = finite && std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
    if (!finite) return det;  // NaN / inf in, NaN / inf out
    if (has_tiny3(kTinyOrient3d, pa, pb, pc, pd)) return orient3d_exact_integer(pa, pb, pc, pd);
    // No product can have underflowed: the permanent is 0 (then so is the
    // determinant, every product having a zero factor) or a normal double,
    // and the adaptive stages are exact.
    if (permanent == 0.0) return 0.0;
    const double errbound = kO3dErrBoundA * permanent;
    if (det > errbound || -det > errbound) return det;
    return orient3d_adapt(pa, pb, pc, pd, permanent);
}

int incircle_perturbed_tie(const double* pa, const double* pb, const double* pc, const double* pd) {
    // Sort the four points lexicographically (pointers identify them).
    const double* s[4] = {pa, pb, pc, pd};
    for (int i = 1; i < 4; ++i) {
        const double* v = s[i];
        int j = i - 1;
        for (; j >= 0 && lex_less(v, s[j]); --j) s[j + 1] = s[j];
        s[j + 1] = v;
    }
    for (int i = 3; i > 1; --i) {
        if (s[i] == pd) return -1;
        int o = 0;
        if (s[i] == pc) o = orient2d_sign(pa, pb, pd);
        else if (s[i] == pb) o = orient2d_sign(pa, pd, pc);
        else o = orient2d_sign(pd, pb, pc);
        if (o != 0) return o;
    }
    // Only reachable when a, b, c are collinear (the caller's precondition).
    return -1;
}

}  // namespace detail

[[noreturn]] void throw_coordinate_error(const std::string& fn, const std::string& where, int axis,
                                         double value) {
    static const char* const kAxis[] = {"x", "y", "z"};
    // The shortest text that reads back as the same double.
    char buf[32];
    const auto res = std::to_chars(buf, buf + sizeof buf, value);
    const std::string v(buf, res.ptr);
    const char* ax = kAxis[axis < 0 || axis > 2 ? 0 : axis];
    std::ostringstream msg;
    msg << fn << ": " << where;
    if (!std::isfinite(value))
        msg << " has a non-finite coordinate (" << ax << " = " << v << ")";
    else
        msg << " has a coordinate beyond +-" << kMaxCoordinate << " (" << ax << " = " << v
            << "): the coordinate limit faultmesh::kMaxCoordinate, within which the exact predicates "
            << "cannot overflow";
    throw std::invalid_argument(msg.str());
}

void check_coordinates(const double* points, std::size_t n, std::size_t stride, std::size_t dims,
                       const char* fn, const char* what) {
    // The common case (all in range) is one pass with a single accumulated flag.
    bool ok = true;
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t k = 0; k < dims; ++k) ok &= coordinate_in_range(points[i * stride + k]);
    if (ok) return;
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t k = 0; k < dims; ++k)
            if (!coordinate_in_range(points[i * stride + k]))
                throw_coordinate_error(fn, std::string(what) + " row " + std::to_string(i),
                                       static_cast<int>(k), points[i * stride + k]);
}

}  // namespace faultmesh
