// SPDX-License-Identifier: Apache-2.0
#pragma once
// How a tiled run shares its tiles between processes (docs/scale.md, "Tiles over MPI ranks"). The
// tile runner and the exact tiled fill / D8 talk only to this interface: one process is the only
// rank (tile_comm.cpp); under mpirun the MPI communicator (host/src/mpi/) sends bytes between
// ranks. Tiles go round-robin to ranks; rank 0 applies every tile's result (writes files) in tile
// order, so the files are those of the single-process run byte for byte.
#include <cstdint>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <terracl/heightfield.hpp>
#include <terracl/tile.hpp>
#include <type_traits>
#include <vector>

namespace terracl::tile {

using Bytes = std::vector<uint8_t>;

class Comm {
 public:
  virtual ~Comm() = default;
  virtual int rank() const { return 0; }
  virtual int size() const { return 1; }
  /// Point to point, one message (blocking).
  virtual void send(int to, const Bytes& bytes) const;
  virtual Bytes recv(int from) const;
  /// At rank 0: every rank's bytes in rank order (elsewhere: empty). Collective.
  virtual std::vector<Bytes> gather(const Bytes& bytes) const { return {bytes}; }
  /// Rank 0's bytes to every rank. Collective.
  virtual void broadcast(Bytes&) const {}
  virtual void barrier() const {}
  int owner(size_t tile) const { return int(tile % size_t(size())); }
  bool mine(size_t tile) const { return owner(tile) == rank(); }
};

/// The process's communicator: MPI's when started under mpirun, else the single rank.
const Comm& comm();
/// Installed by distributed::start (host/src/mpi/).
void set_comm(std::unique_ptr<Comm> c);

/// Tiles 0..n-1: the owner of each computes it; rank 0 applies the results in tile order (its own
/// directly, the others' as they arrive). One process: compute then apply, tile by tile.
void ordered_tiles(const Comm& c, size_t n, const std::function<Bytes(size_t)>& compute,
                   const std::function<void(size_t, const Bytes&)>& apply);

/// ordered_tiles for results that are a tile's core: rank 0's apply gets the owner's core (its
/// cells only: no georef or metadata when it came from another rank).
void ordered_cores(const Comm& c, size_t n, const std::function<Heightfield(size_t)>& compute,
                   const std::function<void(size_t, const Heightfield&)>& apply);

/// A WindowWriter as an EncodingWindowWriter whose bytes are the core's cells (rank 0 writes).
analysis::EncodingWindowWriter cells_writer(const analysis::WindowWriter& write);

/// Appends / reads plain values and arrays (same machine architecture on every rank).
class ByteWriter {
 public:
  template <class T>
  ByteWriter& put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const uint8_t*>(&v);
    m_b.insert(m_b.end(), p, p + sizeof(T));
    return *this;
  }
  template <class T>
  ByteWriter& put_array(const T* v, size_t n) {
    static_assert(std::is_trivially_copyable_v<T>);
    put(uint64_t(n));
    const auto* p = reinterpret_cast<const uint8_t*>(v);
    m_b.insert(m_b.end(), p, p + n * sizeof(T));
    return *this;
  }
  template <class T>
  ByteWriter& put_vector(const std::vector<T>& v) {
    return put_array(v.data(), v.size());
  }
  ByteWriter& put_string(const std::string& s) { return put_array(s.data(), s.size()); }
  Bytes& bytes() { return m_b; }

 private:
  Bytes m_b;
};

class ByteReader {
 public:
  explicit ByteReader(const Bytes& b) : m_b(b) {}
  template <class T>
  T get() {
    T v;
    take(&v, sizeof(T));
    return v;
  }
  template <class T>
  std::vector<T> get_vector() {
    std::vector<T> v(size_t(get<uint64_t>()));
    take(v.data(), v.size() * sizeof(T));
    return v;
  }
  std::string get_string() {
    std::string s(size_t(get<uint64_t>()), '\0');
    take(s.data(), s.size());
    return s;
  }
  bool done() const { return m_at == m_b.size(); }

 private:
  void take(void* dst, size_t n);
  const Bytes& m_b;
  size_t m_at = 0;
};

}  // namespace terracl::tile
