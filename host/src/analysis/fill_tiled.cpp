// SPDX-License-Identifier: Apache-2.0
// Exact tiled Priority-Flood (Barnes 2016, "Parallel priority-flood depression filling for
// trillion cell DEMs", Algorithms 1-4). The filled surface is unique (every cell rises to the
// lowest "highest point" of its paths to an outlet), so it can be assembled from tiles exactly:
//  1. each tile is flooded from its own perimeter: every perimeter cell is a seed with its own
//     label, cells next to nodata or on the raster border drain to the ocean (label 0); labels
//     spread with the flood, and where two labels meet, the pair's spill elevation is the higher
//     of the two filled cells (the lowest such per pair is kept);
//  2. perimeter cells of neighbouring tiles are joined at the higher of their two elevations, and
//     a minimax Dijkstra from the ocean over this graph gives each label its spill elevation;
//  3. each tile is flooded again (same order, same labels) and every cell becomes
//     max(local fill, spill of its label).
// Only max/min of input values are taken, so the result is bit for bit the untiled fill.
// Under MPI (tile_comm.hpp) each rank floods its tiles, rank 0 gathers the edges, solves step 2 and
// broadcasts the spill elevations; step 3's tiles are written by rank 0 in tile order.
#include <fmt/format.h>

#include <algorithm>
#include <terracl/error.hpp>
#include <terracl/tile.hpp>
#include <unordered_map>

#include "analysis/grid.hpp"
#include "analysis/tile_windows.hpp"
#include "tile/tile_comm.hpp"

namespace terracl::analysis {
namespace {

using namespace detail;

struct Edge {
  uint64_t a, b;  // global node ids: 0 = ocean, else 1 + index of a perimeter cell
  float w;
};

using tiles::make_tiles;
using tiles::Tile;

// One tile's flood: the padded core (one-cell NaN frame), its labels and filled values.
struct LocalFlood {
  int cw = 0, ch = 0, pw = 0;
  std::vector<float> z;
  std::vector<uint32_t> label;                // local label: 0 ocean, k >= 1 seed k
  std::vector<uint64_t> seed_node;            // local label -> global node id
  std::unordered_map<uint64_t, float> pairs;  // (la << 32 | lb), la < lb -> lowest spill
  ptrdiff_t off[8];

  size_t index(int x, int y) const { return size_t(y + 1) * pw + size_t(x + 1); }

  // win: cells [wx, wx + win.width) x [wy, ...) of the raster, covering the core plus the halo
  // that lies inside the raster.
  void run(const Heightfield& win, int wx, int wy, const Tile& t, int W, int H, bool record_pairs) {
    cw = t.x1 - t.x0, ch = t.y1 - t.y0, pw = cw + 2;
    z.assign(size_t(pw) * (ch + 2), NAN);
    label.assign(z.size(), 0);
    std::vector<uint8_t> closed(z.size(), 1);
    for (int k = 0; k < 8; ++k) off[k] = ptrdiff_t(kDy[k]) * pw + kDx[k];
    auto raster = [&](int gx, int gy) -> float {  // NaN outside the raster
      if (gx < 0 || gy < 0 || gx >= W || gy >= H) return NAN;
      return win.z[size_t(gy - wy) * win.width + size_t(gx - wx)];
    };
    for (int y = 0; y < ch; ++y)
      for (int x = 0; x < cw; ++x) {
        const float v = raster(t.x0 + x, t.y0 + y);
        z[index(x, y)] = v;
        closed[index(x, y)] = std::isnan(v) ? 1 : 0;
      }
    seed_node.assign(1, 0);
    pairs.clear();
    MinHeap open = make_heap(size_t(2 * (cw + ch)) + 1024);
    for (int y = 0; y < ch; ++y)
      for (int x = 0; x < cw; ++x) {
        const size_t i = index(x, y);
        if (std::isnan(z[i])) continue;
        const bool perimeter = x == 0 || y == 0 || x == cw - 1 || y == ch - 1;
        bool outlet = false;
        for (int k = 0; k < 8 && !outlet; ++k) outlet = std::isnan(raster(t.x0 + x + kDx[k], t.y0 + y + kDy[k]));
        if (!perimeter && !outlet) continue;
        // Perimeter cells are graph nodes (their neighbours in other tiles refer to them); inner
        // outlets drain straight to the ocean.
        if (perimeter) {
          label[i] = uint32_t(seed_node.size());
          seed_node.push_back(1 + uint64_t(t.y0 + y) * uint64_t(W) + uint64_t(t.x0 + x));
        }
        closed[i] = 1;
        open.push(key(z[i], i));
      }
    std::vector<uint32_t> pit;
    size_t pit_head = 0;
    while (!open.empty() || pit_head < pit.size()) {
      size_t c;
      if (pit_head < pit.size()) {
        c = pit[pit_head++];
        if (pit_head == pit.size()) pit.clear(), pit_head = 0;
      } else {
        c = key_index(open.top());
        open.pop();
      }
      const float zc = z[c];
      const uint32_t lc = label[c];
      for (int k = 0; k < 8; ++k) {
        const size_t m = size_t(ptrdiff_t(c) + off[k]);
        if (closed[m]) {
          if (record_pairs && label[m] != lc && !std::isnan(z[m])) {
            const uint32_t a = std::min(lc, label[m]), b = std::max(lc, label[m]);
            const float w = std::max(zc, z[m]);
            auto [it, fresh] = pairs.emplace((uint64_t(a) << 32) | b, w);
            if (!fresh && w < it->second) it->second = w;
          }
          continue;
        }
        closed[m] = 1;
        label[m] = lc;
        if (z[m] <= zc) {
          z[m] = zc;
          pit.push_back(uint32_t(m));
        } else {
          open.push(key(z[m], m));
        }
      }
    }
  }
};

Heightfield read_with_halo(const WindowReader& read, const Tile& t, int W, int H, int& wx, int& wy) {
  return tiles::read_with_halo(read, t, W, H, wx, wy, "fill");
}

}  // namespace

TiledFillStats priority_flood_fill_tiled(int W, int H, int T, const WindowReader& read, const WindowWriter& write,
                                         const Progress& progress) {
  return priority_flood_fill_tiled(W, H, T, read, tile::cells_writer(write), progress);
}

TiledFillStats priority_flood_fill_tiled(int W, int H, int T, const WindowReader& read,
                                         const EncodingWindowWriter& write, const Progress& progress) {
  if (W < 1 || H < 1) fail("fill", "empty raster ({} x {})", W, H);
  if (T < 2) fail("fill", "tile size must be >= 2 cells (got {})", T);
  if (size_t(T + 2) * size_t(T + 2) >= (size_t(1) << 32)) fail("fill", "tile size {} is too large (limit 65534)", T);
  const std::vector<Tile> tiles = make_tiles(W, H, T);
  TiledFillStats st;
  st.tiles = int(tiles.size());
  std::vector<Edge> edges;
  LocalFlood f;
  const double n_steps = 2.0 * tiles.size() + 1;
  const tile::Comm& comm = tile::comm();

  // Pass 1: local floods and the perimeter graph.
  for (size_t ti = 0; ti < tiles.size(); ++ti) {
    if (!comm.mine(ti)) continue;
    const Tile& t = tiles[ti];
    int wx, wy;
    const Heightfield win = read_with_halo(read, t, W, H, wx, wy);
    f.run(win, wx, wy, t, W, H, true);
    for (const auto& [k, w] : f.pairs) edges.push_back({f.seed_node[k >> 32], f.seed_node[k & 0xffffffffu], w});
    // Perimeter cells: to the ocean when the raster ends or nodata is next to them, and to their
    // neighbours in the other tiles (each pair is seen from both sides; the graph keeps both).
    auto raster = [&](int gx, int gy) -> float {
      if (gx < 0 || gy < 0 || gx >= W || gy >= H) return NAN;
      return win.z[size_t(gy - wy) * win.width + size_t(gx - wx)];
    };
    for (size_t s = 1; s < f.seed_node.size(); ++s) {
      const uint64_t id = f.seed_node[s] - 1;
      const int gx = int(id % uint64_t(W)), gy = int(id / uint64_t(W));
      const float zc = raster(gx, gy);
      bool outlet = false;
      for (int k = 0; k < 8; ++k) {
        const int nx = gx + kDx[k], ny = gy + kDy[k];
        const float zn = raster(nx, ny);
        if (std::isnan(zn)) {
          outlet = true;
          continue;
        }
        if (nx >= t.x0 && nx < t.x1 && ny >= t.y0 && ny < t.y1) continue;  // same tile: the flood saw it
        edges.push_back({f.seed_node[s], 1 + uint64_t(ny) * uint64_t(W) + uint64_t(nx), std::max(zc, zn)});
      }
      if (outlet) edges.push_back({0, f.seed_node[s], -INFINITY});
    }
    report_progress(progress, "fill", (ti + 1) / n_steps,
                    fmt::format("tile {}/{}: perimeter graph", ti + 1, tiles.size()));
  }

  // Pass 2: spill elevations, a minimax Dijkstra from the ocean over the perimeter graph (at rank 0).
  std::vector<uint64_t> nodes;
  std::vector<float> spill;
  auto node_index = [&](uint64_t id) {
    return uint32_t(std::lower_bound(nodes.begin(), nodes.end(), id) - nodes.begin());
  };
  if (comm.size() > 1) {
    tile::ByteWriter w;
    w.put_vector(edges);
    const std::vector<tile::Bytes> all = comm.gather(w.bytes());
    std::vector<Edge>().swap(edges);
    for (const tile::Bytes& b : all) {
      tile::ByteReader r(b);
      const std::vector<Edge> part = r.get_vector<Edge>();
      edges.insert(edges.end(), part.begin(), part.end());
    }
  }
  if (comm.rank() == 0) {
    nodes.reserve(edges.size() + 1);
    nodes.push_back(0);
    for (const Edge& e : edges) nodes.push_back(e.a), nodes.push_back(e.b);
    std::sort(nodes.begin(), nodes.end());
    nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
    std::vector<uint32_t> start(nodes.size() + 1, 0);
    for (const Edge& e : edges) start[node_index(e.a) + 1]++, start[node_index(e.b) + 1]++;
    for (size_t i = 0; i < nodes.size(); ++i) start[i + 1] += start[i];
    std::vector<std::pair<uint32_t, float>> adj(start.back());
    {
      std::vector<uint32_t> fillp(start.begin(), start.end() - 1);
      for (const Edge& e : edges) {
        const uint32_t a = node_index(e.a), b = node_index(e.b);
        adj[fillp[a]++] = {b, e.w};
        adj[fillp[b]++] = {a, e.w};
      }
    }
    st.graph_nodes = nodes.size();
    st.graph_edges = edges.size();
    st.graph_bytes = double(nodes.size()) * 12 + double(edges.size()) * (20 + 16);
    std::vector<Edge>().swap(edges);
    spill.assign(nodes.size(), INFINITY);
    {
      using Item = std::pair<float, uint32_t>;
      std::priority_queue<Item, std::vector<Item>, std::greater<Item>> q;
      spill[0] = -INFINITY;
      q.push({-INFINITY, 0});
      while (!q.empty()) {
        const auto [s, u] = q.top();
        q.pop();
        if (s > spill[u]) continue;
        for (uint32_t e = start[u]; e < start[u + 1]; ++e) {
          const auto [v, w] = adj[e];
          const float ns = std::max(s, w);
          if (ns < spill[v]) {
            spill[v] = ns;
            q.push({ns, v});
          }
        }
      }
    }
  }  // rank 0
  if (comm.size() > 1) {
    tile::ByteWriter w;
    if (comm.rank() == 0) w.put_vector(nodes).put_vector(spill);
    comm.broadcast(w.bytes());
    tile::ByteReader r(w.bytes());
    nodes = r.get_vector<uint64_t>();
    spill = r.get_vector<float>();
  }
  report_progress(progress, "fill", (tiles.size() + 1) / n_steps, "spill elevations");

  // Pass 3: flood each tile again and raise it to its labels' spill elevations.
  auto filled = [&](size_t ti) {
    const Tile& t = tiles[ti];
    int wx, wy;
    Heightfield win = read_with_halo(read, t, W, H, wx, wy);
    f.run(win, wx, wy, t, W, H, false);
    std::vector<float> level(f.seed_node.size(), -INFINITY);
    for (size_t s = 1; s < f.seed_node.size(); ++s) level[s] = spill[node_index(f.seed_node[s])];
    Heightfield core = tiles::core_frame(win, t, wx, wy);
    for (int y = 0; y < core.height; ++y)
      for (int x = 0; x < core.width; ++x) {
        const size_t i = f.index(x, y);
        const float v = f.z[i];
        core.at(x, y) = std::isnan(v) ? v : std::max(v, level[f.label[i]]);
      }
    return core;
  };
  // The tile's rank encodes (compresses) its core; rank 0 puts the bytes, in tile order.
  tile::ordered_tiles(
      comm, tiles.size(), [&](size_t ti) { return write.encode(tiles[ti].x0, tiles[ti].y0, filled(ti)); },
      [&](size_t ti, const tile::Bytes& encoded) {
        write.put(tiles[ti].x0, tiles[ti].y0, encoded);
        report_progress(progress, "fill", (tiles.size() + 1 + ti + 1) / n_steps,
                        fmt::format("tile {}/{}: filled", ti + 1, tiles.size()));
      });
  return st;
}

}  // namespace terracl::analysis
