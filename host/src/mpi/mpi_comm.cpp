// SPDX-License-Identifier: Apache-2.0
// Tiled runs over MPI ranks (TERRACL_MPI, docs/scale.md): the communicator the tile runner uses
// (tile_comm.hpp) on MPI_COMM_WORLD, and distributed.hpp. Messages are byte strings sent as a
// 64-bit length and chunks of at most 1 GiB (MPI counts are int). Every wait is a nonblocking
// call tested with short sleeps: Open MPI's blocking calls spin, and a spinning rank took the CPU
// from the others whenever ranks share cores (mpirun --oversubscribe, a loaded node).
#include <mpi.h>
#include <time.h>

#include <algorithm>
#include <climits>
#include <cstdlib>
#include <terracl/distributed.hpp>
#include <terracl/error.hpp>

#include "tile/tile_comm.hpp"

namespace terracl {
namespace {

constexpr int kTagTile = 1801, kTagGather = 1802;
constexpr size_t kChunk = size_t(1) << 30;

bool g_started = false;
int g_rank = 0, g_size = 1, g_local_rank = 0;

// Completes `r`, sleeping between tests (from 20 us up to 1 ms) instead of spinning.
void wait(MPI_Request& r) {
  long ns = 20000;
  for (;;) {
    int done = 0;
    MPI_Test(&r, &done, MPI_STATUS_IGNORE);
    if (done) return;
    const timespec ts{0, ns};
    nanosleep(&ts, nullptr);
    ns = std::min(ns * 2, 1000000L);
  }
}

void send_bytes(int to, int tag, const tile::Bytes& b) {
  const uint64_t n = b.size();
  MPI_Request r;
  MPI_Isend(&n, 1, MPI_UINT64_T, to, tag, MPI_COMM_WORLD, &r);
  wait(r);
  for (size_t at = 0; at < b.size(); at += kChunk) {
    MPI_Isend(b.data() + at, int(std::min(kChunk, b.size() - at)), MPI_BYTE, to, tag, MPI_COMM_WORLD, &r);
    wait(r);
  }
}

tile::Bytes recv_bytes(int from, int tag) {
  uint64_t n = 0;
  MPI_Request r;
  MPI_Irecv(&n, 1, MPI_UINT64_T, from, tag, MPI_COMM_WORLD, &r);
  wait(r);
  tile::Bytes b(n);
  for (size_t at = 0; at < b.size(); at += kChunk) {
    MPI_Irecv(b.data() + at, int(std::min(kChunk, b.size() - at)), MPI_BYTE, from, tag, MPI_COMM_WORLD, &r);
    wait(r);
  }
  return b;
}

class MpiComm : public tile::Comm {
 public:
  int rank() const override { return g_rank; }
  int size() const override { return g_size; }
  void send(int to, const tile::Bytes& b) const override { send_bytes(to, kTagTile, b); }
  tile::Bytes recv(int from) const override { return recv_bytes(from, kTagTile); }
  std::vector<tile::Bytes> gather(const tile::Bytes& b) const override {
    if (g_rank != 0) {
      send_bytes(0, kTagGather, b);
      return {};
    }
    std::vector<tile::Bytes> all{b};
    for (int r = 1; r < g_size; ++r) all.push_back(recv_bytes(r, kTagGather));
    return all;
  }
  void broadcast(tile::Bytes& b) const override {
    uint64_t n = b.size();
    MPI_Request r;
    MPI_Ibcast(&n, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD, &r);
    wait(r);
    b.resize(n);
    for (size_t at = 0; at < b.size(); at += kChunk) {
      MPI_Ibcast(b.data() + at, int(std::min(kChunk, b.size() - at)), MPI_BYTE, 0, MPI_COMM_WORLD, &r);
      wait(r);
    }
  }
  void barrier() const override {
    MPI_Request r;
    MPI_Ibarrier(MPI_COMM_WORLD, &r);
    wait(r);
  }
};

bool launched_by_mpirun() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"})
    if (const char* s = std::getenv(v); s && *s) return true;
  return false;
}

}  // namespace

namespace distributed {

int start(int* argc, char*** argv) {
  if (g_started || !launched_by_mpirun()) return g_size;
  MPI_Init(argc, argv);
  g_started = true;
  MPI_Comm_rank(MPI_COMM_WORLD, &g_rank);
  MPI_Comm_size(MPI_COMM_WORLD, &g_size);
  MPI_Comm node;
  MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, g_rank, MPI_INFO_NULL, &node);
  MPI_Comm_rank(node, &g_local_rank);
  MPI_Comm_free(&node);
  tile::set_comm(std::make_unique<MpiComm>());
  return g_size;
}

int rank() { return g_rank; }
int size() { return g_size; }
int local_rank() { return g_local_rank; }

std::string describe() {
  if (!g_started) return {};
  char lib[MPI_MAX_LIBRARY_VERSION_STRING];
  int len = 0;
  MPI_Get_library_version(lib, &len);
  std::string name(lib, size_t(std::max(0, len)));
  name = name.substr(0, name.find_first_of(",\n"));
  return "MPI (" + name + "), " + std::to_string(g_size) + (g_size == 1 ? " rank" : " ranks");
}

std::vector<std::string> gather_text(const std::string& text) {
  const auto all = tile::comm().gather(tile::Bytes(text.begin(), text.end()));
  std::vector<std::string> out;
  for (const auto& b : all) out.emplace_back(b.begin(), b.end());
  return out;
}

void abort(int code) {
  if (g_started) MPI_Abort(MPI_COMM_WORLD, code);
  std::exit(code);
}

void finish() {
  if (!g_started) return;
  MPI_Finalize();
  g_started = false;
}

}  // namespace distributed
}  // namespace terracl
