// SPDX-License-Identifier: Apache-2.0
#pragma once
/// Tiled, out-of-core execution (docs/scale.md): pipelines run tile by tile through GDAL windows
/// (`terracl run P.json --tile 2048`), and the exact tiled Priority-Flood fill (Barnes 2016) that
/// global stages use. Every stage declares how it tiles (tiling_of): local stages read their
/// footprint as a halo and give the untiled result bit for bit; global stages either have an exact
/// tiled algorithm or refuse with an error naming the limit.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <terracl/heightfield.hpp>
#include <terracl/pipeline.hpp>
#include <terracl/progress.hpp>

namespace terracl {

/// How a stage runs in a tiled pipeline.
enum class TileKind {
  Source,     ///< a reader of a GDAL raster: reads windows
  Sink,       ///< a writer of a GeoTIFF: writes each tile's core
  Local,      ///< a function of a bounded neighbourhood: halo = its footprint, exact
  Window,     ///< a window of the raster (crop): a change of domain, exact
  Global,     ///< an exact tiled algorithm over the whole raster (file to file)
  Untileable  ///< refused, with `limit` saying why and what to do
};

struct StageTiling {
  TileKind kind = TileKind::Untileable;
  int halo = 0;       ///< Local: footprint radius in input cells
  int down = 1;       ///< Local: output cell = block of down x down input cells (downsample)
  int up = 1;         ///< Local: input cell = block of up x up output cells (amplify); halo in input cells
  std::string limit;  ///< Untileable: the reason, for the error message
  /// Local: when set, the halo from the input level's georeferencing (erosion: its step count
  /// follows the metric cell size); replaces `halo`.
  std::function<int(const Georef& level)> halo_of;
  /// Local: when set, run once before the tiles with a reader of the stage's whole input (any
  /// window of its level, computed through the stages before it) and its size; what it returns is
  /// handed to the stage on every tile as metadata "terracl:tile_prepass" (amplify: the detail
  /// blend's correlations, a global quantity). Each tile also gets "terracl:tile_window" = "x y",
  /// its window's first cell in the level.
  std::function<std::string(const std::function<Heightfield(int x, int y, int w, int h)>& read, int w, int h)> prepass;
};

/// The stage table's tiling column: how `stage` (with its resolved options) tiles.
StageTiling tiling_of(const PipelineStage& stage);

struct TileOptions {
  int tile = 0;                ///< core side in cells at each segment's source (0: from the budget, else 2048)
  std::optional<int> halo;     ///< extra halo; nullopt = auto (each stage's footprint)
  uint64_t memory_budget = 0;  ///< bytes of host memory for tiles and GDAL's cache (0: no limit)
  /// --resume: each output is written under a fixed temporary name with a journal beside it
  /// (tile index, checksum of its cells) flushed after every tile; a rerun skips the tiles whose
  /// cells it finds intact in the partial output (docs/scale.md).
  bool resume = false;
};

/// Seam metric of a tiled run with tiles of `tile` cells: the mean squared second difference of
/// `h` (along x and y) on the rows/columns beside a tile border over the same elsewhere. About 1
/// without seams; a kink along the borders (a stage run without enough halo) raises it. NaN when
/// undefined (tile < 2, raster under 3 cells, no border inside the raster).
double tile_seam_ratio(const Heightfield& h, int tile);

/// "512M", "2G", "1.5GiB", "300000000" -> bytes; throws UsageError naming `what` otherwise.
uint64_t parse_memory_size(const std::string& text, const std::string& what);

/// Runs a validated pipeline tile by tile (same outputs as Pipeline::run, bit for bit for exact
/// stages). Throws UsageError naming the stage, its JSON path and the limit when a stage cannot
/// run tiled, or when the budget cannot hold one tile.
/// `tiles`, when given, receives the tile counts (what a --resume run skipped).
struct TileCounts {
  size_t run = 0;         ///< tiles computed by this run (all segments)
  size_t skipped = 0;     ///< --resume: finished by an interrupted run and verified by checksum
  size_t mismatched = 0;  ///< --resume: journaled but the partial output's cells differed: re-run
};
void run_tiled(const Pipeline& pipeline, const TileOptions& tile, const RunOptions& options, RunReport& report,
               TileCounts* tiles = nullptr);

namespace analysis {

/// Reads cells [x, x + w) x [y, y + h) of the whole raster (nodata NaN).
using WindowReader = std::function<Heightfield(int x, int y, int w, int h)>;
/// Receives the final values of the tile whose core starts at (x, y).
/// Under mpirun (terracl/distributed.hpp; a build with TERRACL_MPI) run_tiled and the two tiled
/// algorithms below are collective: every rank calls them, each works on its share of the tiles,
/// and the writer is called on rank 0 only, in tile order (with cores from other ranks carrying
/// their cells only, no georef or metadata).
using WindowWriter = std::function<void(int x, int y, const Heightfield& core)>;
/// A writer in two halves, for outputs that compress: `encode` runs on the rank that computed the
/// core (so that compression divides over the ranks), `put` on rank 0, in tile order, with the
/// bytes `encode` returned (run_tiled's GeoTIFF writer; docs/scale.md, "MPI speed-up").
struct EncodingWindowWriter {
  std::function<std::vector<uint8_t>(int x, int y, const Heightfield& core)> encode;
  std::function<void(int x, int y, const std::vector<uint8_t>& encoded)> put;
};

struct TiledFillStats {
  int tiles = 0;
  size_t graph_nodes = 0, graph_edges = 0;
  double graph_bytes = 0;
};

/// Priority-Flood depression filling (without epsilon) of a width x height raster, tile by tile
/// (Barnes 2016, "Parallel priority-flood depression filling for trillion cell DEMs"): each tile
/// is flooded from its perimeter, the perimeter cells form a graph of spill elevations solved
/// globally, and a second pass raises each tile to its spill levels. Equal, bit for bit, to
/// priority_flood_fill(h, false). Holds one tile (plus a one-cell halo) and the perimeter graph.
TiledFillStats priority_flood_fill_tiled(int width, int height, int tile, const WindowReader& read,
                                         const WindowWriter& write, const Progress& progress = {});
TiledFillStats priority_flood_fill_tiled(int width, int height, int tile, const WindowReader& read,
                                         const EncodingWindowWriter& write, const Progress& progress = {});

struct TiledFlowStats {
  int tiles = 0;
  size_t graph_nodes = 0, graph_edges = 0;
  double graph_bytes = 0;
  size_t valid_cells = 0;
  double outflow_cells = 0;  ///< accumulation leaving the raster or into nodata (= valid_cells)
};

/// D8 flow accumulation of a width x height raster that drains (every valid cell has a strictly
/// lower neighbour or a nodata / off-raster one), tile by tile (Barnes 2017, "Parallel
/// non-divergent flow accumulation for trillion cell digital elevation models"): local
/// accumulation per tile, the flow between tiles solved over a graph of perimeter cells, a second
/// pass adding the inflow. The writer gets float(cells x scale) (nodata NaN): with scale = cell
/// area or 1, equal bit for bit to the `drainage` stage (method d8) untiled, which routes such a
/// surface as it is. A pit or flat cell is refused, naming it. cell_x / cell_y: the whole
/// raster's metric cell size. global_phase = false skips the graph (tests: then tiles differ).
TiledFlowStats d8_accumulation_tiled(int width, int height, int tile, double cell_x, double cell_y, double scale,
                                     const WindowReader& read, const WindowWriter& write, const Progress& progress = {},
                                     bool global_phase = true);
TiledFlowStats d8_accumulation_tiled(int width, int height, int tile, double cell_x, double cell_y, double scale,
                                     const WindowReader& read, const EncodingWindowWriter& write,
                                     const Progress& progress = {}, bool global_phase = true);

}  // namespace analysis
}  // namespace terracl
