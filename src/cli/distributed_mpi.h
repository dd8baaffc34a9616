// sombra — `mpirun -np N sombra render … --distributed`: the ranks of MPI_COMM_WORLD as the
// library's RankExchange (sombra/distributed.h). A build without MPI (no libopenmpi-dev at
// configure time) has the class too, and start() says so.
#pragma once
#include <memory>

#include "sombra/distributed.h"

namespace sombra::cli {

class MpiRanks final : public RankExchange {
public:
    // Initialises MPI (finalised by the destructor); throws sombra::Error in a build without MPI.
    static std::unique_ptr<MpiRanks> start();
    ~MpiRanks() override;
    int rank() const override { return rank_; }
    int size() const override { return size_; }
    std::vector<std::vector<unsigned char>> all_gather(const std::vector<unsigned char>& mine) override;
    std::vector<std::vector<unsigned char>> gather_to_root(const std::vector<unsigned char>& mine) override;
    bool all_ok(bool ok) override;
    // The lowest rank that reported a failure at the last all_ok, −1 if none: the one rank that
    // prints the error, so that a failure every rank meets is one line.
    int first_failed() const { return first_failed_; }
    // After the render's last collective: a later error (writing the image) is this rank's alone.
    void finish() { finished_ = true; }
    // Whether the other ranks still wait for this one's next collective: not after a failure
    // every rank learnt of, nor after the last collective.
    bool open() const { return first_failed_ < 0 && !finished_; }

private:
    MpiRanks() = default;
    int rank_ = 0, size_ = 1, first_failed_ = -1;
    bool finished_ = false;
};

}  // namespace sombra::cli
