// sombra — OpenVDB (.vdb) reading, and a writer for test data. The only file that includes
// OpenVDB's headers (≈ 20 s of CPU to compile: keep them here).
//
// A grid is made dense over its active voxels' bounding box (not bricks): the renderer samples
// one 3-D buffer or image per volume. Memory: 4 bytes × the box's voxel count, plus the sparse
// tree while it is copied (freed before load_volume returns).
#include "scene/volume_io_common.h"

#include "scene/input_file.h"
#include "scene/stderr_capture.h"
#include "scene/volume_io_vdb_checks.h"

#include <openvdb/io/File.h>
#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>

#include <algorithm>
#include <fstream>
#include <cmath>
#include <mutex>
#include <string>

namespace sombra::volume_io {
namespace {

void initialize_once() {
    static std::once_flag flag;
    std::call_once(flag, [] {
        openvdb::initialize();
        // Delayed-load metadata (an index for memory-mapped reading, which sombra does not use) is
        // parsed by OpenVDB from lengths it does not check: unregistered, it is skipped as bytes.
        openvdb::Metadata::unregisterType("__delayedload");
    });
}

bool is_scalar(const openvdb::GridBase& grid) {
    return grid.isType<openvdb::FloatGrid>() || grid.isType<openvdb::DoubleGrid>();
}

std::string describe(const openvdb::GridBase& grid) {
    return "'" + grid.getName() + "' (" + grid.valueType() + ")";
}

// A grid made dense may hold at most kMaxSparseness voxels per active voxel (tiles count as their
// voxels) once it is over kSparseFreeVoxels: two active voxels far apart are not a 2 GB volume.
constexpr std::uint64_t kMaxSparseness = 4096;
constexpr std::uint64_t kSparseFreeVoxels = std::uint64_t(1) << 24;

void check_sparseness(const std::string& path, const std::string& grid, std::uint64_t box, std::uint64_t active) {
    if (box > kSparseFreeVoxels && box / kMaxSparseness > active)
        throw file_error(path, "grid '" + grid + "'",
                         "its active box holds " + std::to_string(box) + " voxels for " + std::to_string(active) +
                             " active ones: too sparse to make dense (at most " + std::to_string(kMaxSparseness) +
                             " voxels per active voxel above " + std::to_string(kSparseFreeVoxels) + ")");
}

template <typename GridT>
Volume dense_volume(const std::string& path, const GridT& grid, const VolumeLoadOptions& options, VolumeLoadReport& report) {
    const openvdb::CoordBBox box = grid.evalActiveVoxelBoundingBox();
    if (box.empty()) throw file_error(path, "grid", "grid '" + grid.getName() + "' has no active voxels");
    const openvdb::Coord size = box.dim();
    Volume volume;
    const std::size_t count = checked_voxel_count(path, {size.x(), size.y(), size.z()});
    if (count > options.max_voxels)
        throw file_error(path, "dims", "the active box of grid '" + grid.getName() + "' (" + std::to_string(size.x()) +
                                           " x " + std::to_string(size.y()) + " x " + std::to_string(size.z()) + ", " +
                                           std::to_string(count) + " voxels) exceeds the limit of " +
                                           std::to_string(options.max_voxels));
    check_sparseness(path, grid.getName(), count, grid.activeVoxelCount());
    volume.dims = {size.x(), size.y(), size.z()};

    const openvdb::math::Transform& xf = grid.transform();
    if (!xf.isLinear())
        throw file_error(path, "transform", "grid '" + grid.getName() + "' has a non-linear (frustum) transform, "
                                            "which sombra cannot place");
    const openvdb::Vec3d lo(box.min().x(), box.min().y(), box.min().z());
    const openvdb::Vec3d origin = xf.indexToWorld(lo);
    std::array<std::array<double, 3>, 3> axes{};
    for (int a = 0; a < 3; ++a) {
        openvdb::Vec3d step = lo;
        step[a] += 1.0;
        const openvdb::Vec3d d = xf.indexToWorld(step) - origin;
        axes[std::size_t(a)] = {d.x(), d.y(), d.z()};
    }
    set_geometry(volume, path, "transform", axes, {origin.x(), origin.y(), origin.z()});

    // Every voxel of the box through a cached accessor, x fastest: inactive voxels and tiles give
    // their value (the background, or a level set's ±band). Not tools::copyToDense and
    // tools::sdfToFogVolume: their headers triple this file's compile time (≈ 60 s of CPU, 1.4 GB).
    volume.voxels.resize(count);
    const auto acc = grid.getConstAccessor();
    const bool level_set = grid.getGridClass() == openvdb::GRID_LEVEL_SET;
    const double band = std::fabs(double(grid.background()));
    std::size_t i = 0;
    for (int z = box.min().z(); z <= box.max().z(); ++z)
        for (int y = box.min().y(); y <= box.max().y(); ++y)
            for (int x = box.min().x(); x <= box.max().x(); ++x, ++i) {
                const double v = double(acc.getValue(openvdb::Coord(x, y, z)));
                // a level set becomes fog as OpenVDB's sdfToFogVolume makes it: 0 outside, a linear
                // ramp over the inner narrow band, 1 deeper inside
                volume.voxels[i] = float(level_set ? (v >= 0 ? 0.0 : std::min(1.0, -v / band)) : v);
            }
    report.grid = grid.getName();
    report.background = level_set ? 0.f : float(grid.background());
    return volume;
}

}  // namespace

Volume read_vdb(const std::string& path, const VolumeLoadOptions& options, VolumeLoadReport& report) {
    initialize_once();
    check_vdb_file(path);  // every length and count OpenVDB will trust, before it reads anything
    detail::StderrCapture capture;  // OpenVDB's warnings (and its libraries') are not the user's
    try {
        // The whole file through io::Stream, reading from a stream we own: OpenVDB does not check
        // its reads for length, so a file cut short would load with the missing voxels made up;
        // the stream's state after the read tells (failbit: a read came back short).
        std::ifstream in(path, std::ios::binary);
        if (!in) throw file_error(path, "", "cannot open the file");
        openvdb::io::Stream stream(in, false);
        if (!in) throw file_error(path, "", "truncated OpenVDB file (a read came back short)");
        openvdb::GridPtrVec grids = *stream.getGrids();
        std::stable_sort(grids.begin(), grids.end(), [](const auto& a, const auto& b) { return a->getName() < b->getName(); });
        // Listed by name (as OpenVDB's File lists them). Without a name: "density" (the name Houdini, Blender
        // and EmberGen give smoke) when it is scalar, else the first float or double grid listed.
        openvdb::GridBase::Ptr base;
        std::string listing;
        for (const openvdb::GridBase::Ptr& g : grids) {
            listing += (listing.empty() ? "" : ", ") + describe(*g);
            if (options.grid.empty() ? is_scalar(*g) && (!base || g->getName() == "density")
                                     : !base && g->getName() == options.grid) {
                if (!is_scalar(*g))
                    throw file_error(path, "grid", "grid " + describe(*g) + " is not a float or double grid");
                base = g;
            }
        }
        if (listing.empty()) throw file_error(path, "grids", "the file holds no grid");
        if (!base)
            throw file_error(path, "grid", (options.grid.empty() ? std::string("no float or double grid")
                                                                 : "no grid named '" + options.grid + "'") +
                                               " (the file holds " + listing + ")");
        Volume volume;
        if (auto g = openvdb::gridPtrCast<openvdb::FloatGrid>(base)) volume = dense_volume(path, *g, options, report);
        else if (auto g = openvdb::gridPtrCast<openvdb::DoubleGrid>(base)) volume = dense_volume(path, *g, options, report);
        else throw file_error(path, "grid", "grid '" + base->getName() + "' changed type while it was read");
        volume.stored_type = std::string(base->isType<openvdb::FloatGrid>() ? "float32" : "float64") +
                             (base->saveFloatAsHalf() ? " (stored as half)" : "");
        return volume;
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {  // openvdb::Exception (IoError, …), std::bad_alloc, …
        throw file_error(path, "", "not a readable OpenVDB file: " + one_line(e.what()));
    }
}

namespace {

template <typename GridT>
typename GridT::Ptr make_grid(const VdbGridSpec& spec) {
    using ValueT = typename GridT::ValueType;
    auto grid = GridT::create(ValueT(spec.background));
    auto acc = grid->getAccessor();
    std::size_t i = 0;
    for (int z = 0; z < spec.dims[2]; ++z)
        for (int y = 0; y < spec.dims[1]; ++y)
            for (int x = 0; x < spec.dims[0]; ++x, ++i)
                if (spec.values[i] != spec.background)
                    acc.setValue(openvdb::Coord(spec.index_min[0] + x, spec.index_min[1] + y, spec.index_min[2] + z),
                                 ValueT(spec.values[i]));
    return grid;
}

}  // namespace

void write_vdb(const std::string& path, const std::vector<VdbGridSpec>& specs) {
    initialize_once();
    openvdb::GridPtrVec grids;
    for (const VdbGridSpec& spec : specs) {
        if (spec.values.size() != std::size_t(spec.dims[0]) * std::size_t(spec.dims[1]) * std::size_t(spec.dims[2]))
            throw file_error(path, spec.name, "values do not match the dims");
        openvdb::GridBase::Ptr grid;
        if (spec.kind == VdbGridSpec::Kind::Float) grid = make_grid<openvdb::FloatGrid>(spec);
        else if (spec.kind == VdbGridSpec::Kind::Double) grid = make_grid<openvdb::DoubleGrid>(spec);
        else {
            auto v = openvdb::Vec3SGrid::create();
            v->getAccessor().setValue(openvdb::Coord(0, 0, 0), openvdb::Vec3s(1, 2, 3));
            grid = v;
        }
        grid->setName(spec.name);
        grid->setGridClass(spec.level_set ? openvdb::GRID_LEVEL_SET : openvdb::GRID_FOG_VOLUME);
        // OpenVDB multiplies row vectors: world = (i, j, k, 1) · Mᵀ of our column-vector M.
        openvdb::math::Mat4d m;
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c) m[c][r] = spec.index_to_world[std::size_t(r * 4 + c)];
        grid->setTransform(openvdb::math::Transform::createLinearTransform(m));
        for (int probe = 0; probe < 4; ++probe) {  // the file says what index_to_world says
            const openvdb::Vec3d ijk(probe == 1 ? 1 : 0, probe == 2 ? 1 : 0, probe == 3 ? 1 : 0);
            const openvdb::Vec3d w = grid->transform().indexToWorld(ijk);
            for (int r = 0; r < 3; ++r) {
                const double want = spec.index_to_world[std::size_t(r * 4 + 3)] +
                                    (probe ? spec.index_to_world[std::size_t(r * 4 + probe - 1)] : 0.0);
                if (std::fabs(w[r] - want) > 1e-9 * (1 + std::fabs(want)))
                    throw file_error(path, spec.name, "OpenVDB did not take the transform as given");
            }
        }
        grids.push_back(grid);
    }
    try {
        openvdb::io::File file(path);
        file.write(grids);
        file.close();
    } catch (const std::exception& e) {
        throw file_error(path, "", "cannot write the OpenVDB file: " + one_line(e.what()));
    }
}

}  // namespace sombra::volume_io
