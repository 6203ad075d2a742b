// SPDX-License-Identifier: Apache-2.0
// The single-process side of tiled runs over ranks (tile_comm.hpp): one rank that computes and
// applies every tile, and, in a build without TERRACL_MPI, the distributed.hpp functions for a
// process that is the only rank. The MPI side is host/src/mpi/mpi_comm.cpp.
#include "tile/tile_comm.hpp"

#include <cstdlib>
#include <terracl/distributed.hpp>
#include <terracl/error.hpp>

namespace terracl::tile {
namespace {
std::unique_ptr<Comm>& installed() {
  static std::unique_ptr<Comm> c = std::make_unique<Comm>();
  return c;
}
}  // namespace

void Comm::send(int to, const Bytes&) const { fail("tile", "internal: send to rank {} in a single-process run", to); }
Bytes Comm::recv(int from) const { fail("tile", "internal: receive from rank {} in a single-process run", from); }

const Comm& comm() { return *installed(); }
void set_comm(std::unique_ptr<Comm> c) { installed() = std::move(c); }

void ordered_tiles(const Comm& c, size_t n, const std::function<Bytes(size_t)>& compute,
                   const std::function<void(size_t, const Bytes&)>& apply) {
  for (size_t t = 0; t < n; ++t) {
    const int owner = c.owner(t);
    if (c.rank() == 0) {
      apply(t, owner == 0 ? compute(t) : c.recv(owner));
    } else if (owner == c.rank()) {
      c.send(0, compute(t));
    }
  }
}

namespace {
// A tile's core as a message: width, height, cells.
Bytes pack_core(const Heightfield& h) {
  ByteWriter w;
  w.put(int32_t(h.width)).put(int32_t(h.height)).put_vector(h.z);
  return std::move(w.bytes());
}

Heightfield unpack_core(const Bytes& b) {
  ByteReader r(b);
  const int w = r.get<int32_t>(), h = r.get<int32_t>();
  Heightfield core(w, h);
  core.z = r.get_vector<float>();
  if (core.z.size() != size_t(w) * size_t(h)) fail("tile", "internal: a {} x {} core of {} cells", w, h, core.z.size());
  return core;
}
}  // namespace

void ordered_cores(const Comm& c, size_t n, const std::function<Heightfield(size_t)>& compute,
                   const std::function<void(size_t, const Heightfield&)>& apply) {
  if (c.size() == 1) {
    for (size_t t = 0; t < n; ++t) apply(t, compute(t));
    return;
  }
  ordered_tiles(
      c, n,
      [&](size_t t) { return pack_core(compute(t)); }, [&](size_t t, const Bytes& b) { apply(t, unpack_core(b)); });
}

analysis::EncodingWindowWriter cells_writer(const analysis::WindowWriter& write) {
  return {[](int, int, const Heightfield& h) { return pack_core(h); },
          [write](int x, int y, const Bytes& b) { write(x, y, unpack_core(b)); }};
}

void ByteReader::take(void* dst, size_t n) {
  if (n > m_b.size() - m_at) fail("tile", "internal: message of {} bytes read past its end", m_b.size());
  if (n) std::memcpy(dst, m_b.data() + m_at, n);
  m_at += n;
}

}  // namespace terracl::tile

#ifndef TERRACL_HAVE_MPI
namespace terracl::distributed {
int start(int*, char***) { return 1; }
int rank() { return 0; }
int size() { return 1; }
int local_rank() { return 0; }
std::string describe() { return {}; }
std::vector<std::string> gather_text(const std::string& text) { return {text}; }
void abort(int code) { std::exit(code); }
void finish() {}
}  // namespace terracl::distributed
#endif
