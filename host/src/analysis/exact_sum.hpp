// SPDX-License-Identifier: Apache-2.0
#pragma once
// An exact, order-independent sum of doubles: every finite double is an integer multiple of
// 2^-1074 below 2^1024, so a fixed-point accumulator of 32-bit digits over that range holds any
// sum exactly. Tiles' partial sums merge into the same total in any order, which makes the tiled
// metrics equal the untiled ones bit for bit (docs/scale.md, "Tiled metrics").
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

namespace terracl::analysis {

class ExactSum {
 public:
  static constexpr int kDigits = 70;  // 2240 bits: 2098 for the range, the rest for carries
  void add(double v) {
    if (v == 0 || !std::isfinite(v)) return;
    int e = 0;
    const double m = std::frexp(std::fabs(v), &e);  // |v| = m 2^e, m in [0.5, 1)
    // |v| = M 2^(e - 53) with M a 53-bit integer; subnormals are exact at 2^-1074.
    int p = e - 53 + 1074;
    uint64_t M = uint64_t(std::ldexp(m, 53));
    if (p < 0) {
      M >>= -p;  // exact: a subnormal's low bits are zero
      p = 0;
    }
    const int k = p / 32, sh = p % 32;
    const unsigned __int128 w = static_cast<unsigned __int128>(M) << sh;
    const int64_t sign = v < 0 ? -1 : 1;
    for (int i = 0; i < 3 && k + i < kDigits; ++i) m_d[k + i] += sign * int64_t(uint64_t(w >> (32 * i)) & 0xffffffffu);
    if (++m_pending >= (1 << 28)) normalize();
  }
  void merge(const ExactSum& o) {
    ExactSum b = o;
    b.normalize();
    normalize();
    for (int i = 0; i < kDigits; ++i) m_d[i] += b.m_d[i];
    normalize();
  }
  /// The sum rounded to a double, by a fixed procedure on the canonical digits (so equal sums give
  /// equal doubles whatever the order of the additions).
  double value() const {
    ExactSum c = *this;
    c.normalize();
    long double r = 0;
    for (int i = kDigits - 1; i >= 0; --i) r += std::ldexp(static_cast<long double>(c.m_d[i]), 32 * i - 1074);
    return double(r);
  }
  std::vector<int64_t> digits() const {
    ExactSum c = *this;
    c.normalize();
    return std::vector<int64_t>(c.m_d, c.m_d + kDigits);
  }
  static ExactSum from_digits(const int64_t* d) {
    ExactSum s;
    std::memcpy(s.m_d, d, sizeof(s.m_d));
    return s;
  }

 private:
  // Digits 0..kDigits-2 in [0, 2^32), the top one signed: one representation per value.
  void normalize() {
    for (int i = 0; i + 1 < kDigits; ++i) {
      const int64_t carry = m_d[i] >> 32;  // floor division by 2^32
      m_d[i] -= carry * (int64_t(1) << 32);
      m_d[i + 1] += carry;
    }
    m_pending = 0;
  }
  int64_t m_d[kDigits] = {};
  int m_pending = 0;
};

}  // namespace terracl::analysis
