// sombra — the MPI transport of distributed renders (distributed_mpi.h).
#include "cli/distributed_mpi.h"

#include <climits>

#ifdef SOMBRA_HAS_MPI
#define OMPI_SKIP_MPICXX 1  // the C API only: MPI's deprecated C++ bindings need a library we do not link
#define MPICH_SKIP_MPICXX 1
#include <mpi.h>
#endif

namespace sombra::cli {

#ifdef SOMBRA_HAS_MPI

namespace {
// Counts and displacements of a gather of `sizes` bytes; MPI counts are ints.
std::vector<int> displacements(const std::vector<int>& sizes) {
    std::vector<int> at(sizes.size(), 0);
    long long total = 0;
    for (std::size_t r = 0; r < sizes.size(); ++r) {
        at[r] = int(total);
        total += sizes[r];
        if (total > INT_MAX) throw Error("--distributed: more than 2 GiB to gather in one message");
    }
    return at;
}

std::vector<std::vector<unsigned char>> split(const std::vector<unsigned char>& all, const std::vector<int>& sizes,
                                              const std::vector<int>& at) {
    std::vector<std::vector<unsigned char>> parts;
    for (std::size_t r = 0; r < sizes.size(); ++r) parts.emplace_back(all.begin() + at[r], all.begin() + at[r] + sizes[r]);
    return parts;
}

int byte_count(const std::vector<unsigned char>& mine) {
    if (mine.size() > std::size_t(INT_MAX)) throw Error("--distributed: more than 2 GiB in one message");
    return int(mine.size());
}
}  // namespace

std::unique_ptr<MpiRanks> MpiRanks::start() {
    int initialised = 0;
    MPI_Initialized(&initialised);
    if (!initialised) MPI_Init(nullptr, nullptr);
    std::unique_ptr<MpiRanks> ranks(new MpiRanks());
    MPI_Comm_rank(MPI_COMM_WORLD, &ranks->rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &ranks->size_);
    return ranks;
}

MpiRanks::~MpiRanks() {
    int finalised = 0;
    MPI_Finalized(&finalised);
    if (!finalised) MPI_Finalize();
}

std::vector<std::vector<unsigned char>> MpiRanks::all_gather(const std::vector<unsigned char>& mine) {
    int own = byte_count(mine);
    std::vector<int> sizes(std::size_t(size_), 0);
    MPI_Allgather(&own, 1, MPI_INT, sizes.data(), 1, MPI_INT, MPI_COMM_WORLD);
    std::vector<int> at = displacements(sizes);
    std::vector<unsigned char> all(std::size_t(at.back()) + std::size_t(sizes.back()));
    MPI_Allgatherv(mine.data(), own, MPI_BYTE, all.data(), sizes.data(), at.data(), MPI_BYTE, MPI_COMM_WORLD);
    return split(all, sizes, at);
}

std::vector<std::vector<unsigned char>> MpiRanks::gather_to_root(const std::vector<unsigned char>& mine) {
    int own = byte_count(mine);
    std::vector<int> sizes(std::size_t(size_), 0);
    MPI_Gather(&own, 1, MPI_INT, sizes.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
    std::vector<int> at = rank_ == 0 ? displacements(sizes) : std::vector<int>(std::size_t(size_), 0);
    std::vector<unsigned char> all(rank_ == 0 ? std::size_t(at.back()) + std::size_t(sizes.back()) : 0);
    MPI_Gatherv(mine.data(), own, MPI_BYTE, all.data(), sizes.data(), at.data(), MPI_BYTE, 0, MPI_COMM_WORLD);
    return rank_ == 0 ? split(all, sizes, at) : std::vector<std::vector<unsigned char>>{};
}

bool MpiRanks::all_ok(bool ok) {
    int mine = ok ? INT_MAX : rank_, first = INT_MAX;
    MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    first_failed_ = first == INT_MAX ? -1 : first;
    return first_failed_ < 0;
}

#else  // built without MPI

std::unique_ptr<MpiRanks> MpiRanks::start() {
    throw Error("--distributed: this sombra was built without MPI (scripts/install-deps.sh installs libopenmpi-dev; then rebuild)");
}
MpiRanks::~MpiRanks() = default;
std::vector<std::vector<unsigned char>> MpiRanks::all_gather(const std::vector<unsigned char>& mine) { return {mine}; }
std::vector<std::vector<unsigned char>> MpiRanks::gather_to_root(const std::vector<unsigned char>& mine) { return {mine}; }
bool MpiRanks::all_ok(bool ok) { return ok; }

#endif

}  // namespace sombra::cli
