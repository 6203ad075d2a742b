// SPDX-License-Identifier: Apache-2.0
// Exact tiled D8 flow accumulation (Barnes 2017, "Parallel non-divergent flow accumulation for
// trillion cell digital elevation models on desktops or clusters"):
//  1. each tile (plus a one-cell halo, so that every core cell sees all its neighbours) gets its
//     D8 directions and its local accumulation (Kahn's order inside the tile); every perimeter
//     cell records the cell where its downstream path leaves the tile (its exit), and every exit
//     records its local accumulation and the cell of the next tile it drains into;
//  2. over the graph of perimeter cells (entry -> exit inside a tile, exit -> entry across tiles,
//     acyclic since D8 descends strictly) Kahn's order gives the flow entering each tile at each
//     perimeter cell from the other tiles;
//  3. each tile is accumulated again with that inflow added at its perimeter cells.
// Accumulation counts cells in uint64 (exact in any order); the untiled run's double sums of whole
// cells are exact too, so both give the same count, and area = count x cell area is the same
// product. The directions are those of the untiled run when the surface already drains (every
// cell has a lower neighbour or is an outlet: d8_flow then routes it as is); on a surface with
// pits or flats the untiled run resolves them with the epsilon flood, whose steps follow one
// global processing order that tiles cannot reproduce, so the tiled run refuses it.
// Under MPI (tile_comm.hpp) each rank runs pass 1 on its tiles, rank 0 gathers the links and exits,
// solves pass 2 and broadcasts the inflow; pass 3's tiles are written by rank 0 in tile order.
#include <fmt/format.h>

#include <algorithm>
#include <terracl/error.hpp>
#include <terracl/tile.hpp>

#include "analysis/grid.hpp"
#include "analysis/tile_windows.hpp"
#include "tile/tile_comm.hpp"

namespace terracl::analysis {
namespace {

using namespace detail;

constexpr uint32_t kNone = 0xffffffffu;

using tiles::make_tiles;
using tiles::Tile;

// One tile's directions and local accumulation.
struct LocalFlow {
  int cw = 0, ch = 0;
  std::vector<uint8_t> dir;     // per core cell: 0..7, kOutlet, kNoFlow
  std::vector<uint64_t> acc;    // per core cell: cells upstream inside the tile (+ inflow in pass 3)
  std::vector<uint32_t> order;  // topological (upstream first)
  std::vector<uint32_t> exit;   // per core cell: core index of the cell where its path leaves the tile
  ptrdiff_t coff[8];            // neighbour offsets in the core

  bool leaves(int x, int y, uint8_t d) const {
    const int nx = x + kDx[d], ny = y + kDy[d];
    return nx < 0 || ny < 0 || nx >= cw || ny >= ch;
  }

  // win: the window [wx, wx + win.width) x [wy, ...) of the raster that holds the core and the
  // halo cells inside the raster. inflow: per core cell, flow entering from other tiles (or empty).
  void run(const Heightfield& win, int wx, int wy, const Tile& t, const double inv_dist[8],
           const std::vector<uint64_t>& inflow, bool exits) {
    cw = t.x1 - t.x0, ch = t.y1 - t.y0;
    const size_t n = size_t(cw) * ch;
    for (int k = 0; k < 8; ++k) coff[k] = ptrdiff_t(kDy[k]) * cw + kDx[k];
    ptrdiff_t woff[8];
    for (int k = 0; k < 8; ++k) woff[k] = ptrdiff_t(kDy[k]) * win.width + kDx[k];
    dir.assign(n, kNoFlow);
    acc.assign(n, 0);
    std::vector<uint8_t> donors(n, 0);
    for (int y = 0; y < ch; ++y)
      for (int x = 0; x < cw; ++x) {
        const int lx = t.x0 + x - wx, ly = t.y0 + y - wy;
        const size_t i = size_t(y) * cw + x;
        if (std::isnan(win.z[size_t(ly) * win.width + lx])) continue;
        // The window ends where the raster ends or one cell beyond the core: the core cell sees
        // exactly the neighbours it has in the whole raster.
        const uint8_t d = d8_receiver(win.z.data(), win.width, win.height, lx, ly, woff, inv_dist);
        if (d == kOutlet) {
          bool outlet = false;
          for (int k = 0; k < 8 && !outlet; ++k) {
            const int nx = lx + kDx[k], ny = ly + kDy[k];
            outlet = nx < 0 || ny < 0 || nx >= win.width || ny >= win.height ||
                     std::isnan(win.z[size_t(ny) * win.width + nx]);
          }
          if (!outlet)
            fail("drainage",
                 "cell ({}, {}) at {} m has no lower neighbour (a pit or a flat): the tiled D8 accumulation needs a "
                 "surface that drains, because the untiled run resolves pits and flats with an epsilon flood whose "
                 "steps follow one global order that tiles cannot reproduce; run fill_depressions with epsilon "
                 "untiled first, or drainage untiled",
                 t.x0 + x, t.y0 + y, win.z[size_t(ly) * win.width + lx]);
        }
        dir[i] = d;
        acc[i] = 1 + (inflow.empty() ? 0 : inflow[i]);
        if (d < 8 && !leaves(x, y, d)) donors[size_t(ptrdiff_t(i) + coff[d])]++;
      }
    order.clear();
    std::vector<uint32_t> stack;
    for (size_t i = 0; i < n; ++i)
      if (dir[i] != kNoFlow && donors[i] == 0) stack.push_back(uint32_t(i));
    while (!stack.empty()) {
      const uint32_t i = stack.back();
      stack.pop_back();
      order.push_back(i);
      const uint8_t d = dir[i];
      if (d >= 8 || leaves(int(i % cw), int(i / cw), d)) continue;
      const size_t j = size_t(ptrdiff_t(i) + coff[d]);
      acc[j] += acc[i];
      if (--donors[j] == 0) stack.push_back(uint32_t(j));
    }
    if (!exits) return;
    // Downstream first: a cell's exit is its receiver's, or itself where its flow leaves the tile.
    exit.assign(n, kNone);
    for (size_t o = order.size(); o-- > 0;) {
      const uint32_t i = order[o];
      const uint8_t d = dir[i];
      if (d == kOutlet) continue;
      exit[i] = leaves(int(i % cw), int(i / cw), d) ? i : exit[size_t(ptrdiff_t(i) + coff[d])];
    }
  }
};

Heightfield read_with_halo(const WindowReader& read, const Tile& t, int W, int H, int& wx, int& wy) {
  return tiles::read_with_halo(read, t, W, H, wx, wy, "drainage");
}

// Perimeter cells of a tile, in a fixed order (each once).
template <class F>
void for_perimeter(const Tile& t, F&& f) {
  const int cw = t.x1 - t.x0, ch = t.y1 - t.y0;
  for (int y = 0; y < ch; ++y)
    for (int x = 0; x < cw; ++x) {
      if (y != 0 && y != ch - 1 && x != 0 && x != cw - 1) x = cw - 1;
      f(x, y);
    }
}

}  // namespace

TiledFlowStats d8_accumulation_tiled(int W, int H, int T, double cell_x, double cell_y, double scale,
                                     const WindowReader& read, const WindowWriter& write, const Progress& progress,
                                     bool global_phase) {
  return d8_accumulation_tiled(W, H, T, cell_x, cell_y, scale, read, tile::cells_writer(write), progress, global_phase);
}

TiledFlowStats d8_accumulation_tiled(int W, int H, int T, double cell_x, double cell_y, double scale,
                                     const WindowReader& read, const EncodingWindowWriter& write,
                                     const Progress& progress, bool global_phase) {
  const char* stage = "drainage";
  if (W < 1 || H < 1) fail(stage, "empty raster ({} x {})", W, H);
  if (T < 2) fail(stage, "tile size must be >= 2 cells (got {})", T);
  if (size_t(T) * size_t(T) >= (size_t(1) << 32)) fail(stage, "tile size {} is too large (limit 65535)", T);
  if (!(cell_x > 0) || !(cell_y > 0)) fail(stage, "cell size must be positive (got {} x {})", cell_x, cell_y);
  // The same distances as neighbour_distances() of the untiled run.
  double inv_dist[8];
  {
    const double dg = std::hypot(cell_x, cell_y);
    for (int k = 0; k < 8; ++k)
      inv_dist[k] = 1.0 / ((kDx[k] != 0 && kDy[k] != 0) ? dg : (kDx[k] != 0 ? cell_x : cell_y));
  }
  const std::vector<Tile> tiles = make_tiles(W, H, T);
  TiledFlowStats st;
  st.tiles = int(tiles.size());
  const double n_steps = 2.0 * tiles.size() + 1;
  auto gid = [W](const Tile& t, int x, int y) { return uint64_t(t.y0 + y) * uint64_t(W) + uint64_t(t.x0 + x); };
  LocalFlow f;
  const std::vector<uint64_t> no_inflow;

  // Pass 1: local accumulation; perimeter cell -> exit links, exit -> next tile's cell links.
  struct Link {
    uint64_t from, to;
  };
  struct Exit {
    uint64_t cell, into, local;
  };
  std::vector<Link> links;
  std::vector<Exit> exits;
  const tile::Comm& comm = tile::comm();
  for (size_t ti = 0; ti < tiles.size(); ++ti) {
    if (!comm.mine(ti)) continue;
    const Tile& t = tiles[ti];
    int wx, wy;
    const Heightfield win = read_with_halo(read, t, W, H, wx, wy);
    f.run(win, wx, wy, t, inv_dist, no_inflow, true);
    for_perimeter(t, [&](int x, int y) {
      const size_t i = size_t(y) * f.cw + x;
      if (f.exit[i] == kNone) return;  // nodata, or its path ends at an outlet inside the tile
      const uint32_t e = f.exit[i];
      links.push_back({gid(t, x, y), gid(t, int(e % f.cw), int(e / f.cw))});
      if (e == i) {
        const uint8_t d = f.dir[i];
        exits.push_back({gid(t, x, y), gid(t, x + kDx[d], y + kDy[d]), f.acc[i]});
      }
    });
    report_progress(progress, stage, (ti + 1) / n_steps,
                    fmt::format("tile {}/{}: directions and perimeter links", ti + 1, tiles.size()));
  }

  // Pass 2: inflow at every perimeter cell, in Kahn's order over the perimeter graph. in(c): flow
  // entering cell c from other tiles; out(e): flow leaving exit e = its local accumulation plus
  // the inflow of every perimeter cell whose path leaves the tile at e.
  std::vector<uint64_t> nodes;
  std::vector<uint64_t> in;
  if (comm.size() > 1) {  // rank 0 gets every rank's links and exits
    tile::ByteWriter w;
    w.put_vector(links).put_vector(exits);
    const std::vector<tile::Bytes> all = comm.gather(w.bytes());
    for (size_t r = 1; r < all.size(); ++r) {
      tile::ByteReader rd(all[r]);
      const auto l = rd.get_vector<Link>();
      const auto e = rd.get_vector<Exit>();
      links.insert(links.end(), l.begin(), l.end());
      exits.insert(exits.end(), e.begin(), e.end());
    }
  }
  auto node_index = [&](uint64_t id) {
    const auto it = std::lower_bound(nodes.begin(), nodes.end(), id);
    return it != nodes.end() && *it == id ? uint32_t(it - nodes.begin()) : kNone;
  };
  if (comm.rank() == 0) {
    nodes.reserve(2 * exits.size() + links.size());
    for (const Link& l : links) nodes.push_back(l.from);
    for (const Exit& e : exits) nodes.push_back(e.into);
    std::sort(nodes.begin(), nodes.end());
    nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
    const size_t nn = nodes.size();
    std::vector<uint32_t> link_of(nn, kNone), into_of(nn, kNone), deg_in(nn, 0), deg_out(nn, 0);
    in.assign(nn, 0);
    std::vector<uint64_t> out(nn, 0);
    for (const Link& l : links) {
      const uint32_t a = node_index(l.from), b = node_index(l.to);
      link_of[a] = b;
      deg_out[b]++;
    }
    for (const Exit& e : exits) {
      const uint32_t a = node_index(e.cell), b = node_index(e.into);
      into_of[a] = b;
      out[a] = e.local;
      deg_in[b]++;
    }
    st.graph_nodes = nn;
    st.graph_edges = links.size() + exits.size();
    st.graph_bytes = double(nn) * (8 + 4 * 4 + 2 * 8) + double(links.size()) * 16 + double(exits.size()) * 24;
    std::vector<Link>().swap(links);
    std::vector<Exit>().swap(exits);
    if (global_phase) {
      std::vector<uint32_t> stack;  // node << 1 | (1 for out, 0 for in)
      for (uint32_t v = 0; v < nn; ++v)
        if (deg_in[v] == 0) stack.push_back(v << 1);
      size_t done = 0;
      while (!stack.empty()) {
        const uint32_t s = stack.back();
        stack.pop_back();
        ++done;
        const uint32_t v = s >> 1;
        if ((s & 1) == 0) {
          const uint32_t e = link_of[v];
          if (e == kNone) continue;
          out[e] += in[v];
          if (--deg_out[e] == 0) stack.push_back(e << 1 | 1);
        } else {
          const uint32_t r = into_of[v];
          in[r] += out[v];
          if (--deg_in[r] == 0) stack.push_back(r << 1);
        }
      }
      size_t expected = nn;
      for (uint32_t v = 0; v < nn; ++v) expected += into_of[v] != kNone;
      if (done != expected)
        fail(stage, "internal: the perimeter flow graph has a cycle ({} of {} nodes ordered)", done, expected);
    }
  }  // rank 0
  if (comm.size() > 1) {
    tile::ByteWriter w;
    if (comm.rank() == 0) w.put_vector(nodes).put_vector(in);
    comm.broadcast(w.bytes());
    tile::ByteReader r(w.bytes());
    nodes = r.get_vector<uint64_t>();
    in = r.get_vector<uint64_t>();
  }
  report_progress(progress, stage, (tiles.size() + 1) / n_steps, "inflow at tile perimeters");

  // Pass 3: accumulate each tile again with its inflow.
  std::vector<uint64_t> inflow;
  auto accumulated = [&](size_t ti) {
    const Tile& t = tiles[ti];
    int wx, wy;
    const Heightfield win = read_with_halo(read, t, W, H, wx, wy);
    const int cw = t.x1 - t.x0, ch = t.y1 - t.y0;
    inflow.assign(size_t(cw) * ch, 0);
    for_perimeter(t, [&](int x, int y) {
      const uint32_t v = node_index(gid(t, x, y));
      if (v != kNone) inflow[size_t(y) * cw + x] = in[v];
    });
    f.run(win, wx, wy, t, inv_dist, inflow, false);
    Heightfield core = tiles::core_frame(win, t, wx, wy);
    for (size_t i = 0; i < core.z.size(); ++i) {
      if (f.dir[i] == kNoFlow) {
        core.z[i] = NAN;
        continue;
      }
      st.valid_cells++;
      if (f.dir[i] == kOutlet) st.outflow_cells += f.acc[i];
      // As run_drainage: float(double cells x area).
      core.z[i] = float(double(f.acc[i]) * scale);
    }
    return core;
  };
  // The tile's rank encodes (compresses) its core; rank 0 puts the bytes, in tile order.
  tile::ordered_tiles(
      comm, tiles.size(), [&](size_t ti) { return write.encode(tiles[ti].x0, tiles[ti].y0, accumulated(ti)); },
      [&](size_t ti, const tile::Bytes& encoded) {
        write.put(tiles[ti].x0, tiles[ti].y0, encoded);
        report_progress(progress, stage, (tiles.size() + 1 + ti + 1) / n_steps,
                        fmt::format("tile {}/{}: accumulated", ti + 1, tiles.size()));
      });
  if (comm.size() > 1) {  // the counts of every rank's tiles, summed at rank 0
    tile::ByteWriter w;
    w.put(uint64_t(st.valid_cells)).put(st.outflow_cells);
    const std::vector<tile::Bytes> all = comm.gather(w.bytes());
    if (comm.rank() == 0) {
      st.valid_cells = 0, st.outflow_cells = 0;
      for (const tile::Bytes& b : all) {
        tile::ByteReader r(b);
        st.valid_cells += size_t(r.get<uint64_t>());
        st.outflow_cells += r.get<double>();
      }
    }
  }
  return st;
}

}  // namespace terracl::analysis
