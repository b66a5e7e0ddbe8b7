// nn.cpp - the same near queries answered by nanoflann's exact k-d tree
// (Debian libnanoflann-dev 1.4.3), for issue 12's near-query floor
// (session 36; README.md beside this file).
//
//   nn DIM PREFIX [LEAF...]
//
// Reads PREFIX.pos, PREFIX.q and PREFIX.d2 (nnrec's), builds a k-d tree of
// the particle centres (double coordinates, squared L2) per leaf size, and
// answers every query with its nearest neighbour (k = 1) in walk order.
// Prints ns a query (CPU time, best of 3), the index's bytes a particle, and
// how many answers differ from the engine tree's squared distances (exact,
// or a lower bound past the far thresholds: then below nanoflann's; one
// above it would be a wrong bound, counted apart).
#include <nanoflann.hpp>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <vector>

static std::vector<int64_t> load(const char *prefix, const char *ext)
{
    char path[4096];
    std::snprintf(path, sizeof path, "%s.%s", prefix, ext);
    FILE *f = std::fopen(path, "rb");
    if (!f) { std::fprintf(stderr, "nn: cannot open %s\n", path); std::exit(1); }
    std::fseek(f, 0, SEEK_END);
    const long bytes = std::ftell(f);
    std::fseek(f, 0, SEEK_SET);
    std::vector<int64_t> v((size_t)bytes / 8);
    if (std::fread(v.data(), 8, v.size(), f) != v.size()) { std::fprintf(stderr, "nn: short %s\n", path); std::exit(1); }
    std::fclose(f);
    return v;
}

static double cpu_now()
{
    timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

template <int DIM> struct cloud {
    std::vector<double> x;
    size_t kdtree_get_point_count() const { return x.size() / DIM; }
    double kdtree_get_pt(size_t i, size_t a) const { return x[i * DIM + a]; }
    template <class BB> bool kdtree_get_bbox(BB &) const { return false; }
};

template <int DIM> static int run(const char *prefix, int nleaf, char **leaves)
{
    const std::vector<int64_t> pos = load(prefix, "pos"), q = load(prefix, "q"), d2 = load(prefix, "d2");
    cloud<DIM> c;
    c.x.assign(pos.begin(), pos.end());
    const size_t n = pos.size() / DIM, nq = q.size() / DIM;
    std::vector<double> qd(q.begin(), q.end());
    typedef nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, cloud<DIM>>, cloud<DIM>, DIM> kd;
    for (int l = 0; l < nleaf; l++) {
        const int leaf = std::atoi(leaves[l]);
        const double tb = cpu_now();
        kd index(DIM, c, nanoflann::KDTreeSingleIndexAdaptorParams(leaf));
        index.buildIndex();
        const double tbuild = cpu_now() - tb;
        double best = INFINITY, sum = 0;
        size_t bad = 0, above = 0;
        for (int rep = 0; rep < 3; rep++) {
            sum = 0;
            bad = 0;
            above = 0;
            const double t0 = cpu_now();
            for (size_t i = 0; i < nq; i++) {
                size_t idx;
                double dist2;
                nanoflann::KNNResultSet<double> res(1);
                res.init(&idx, &dist2);
                index.findNeighbors(res, &qd[i * DIM], nanoflann::SearchParams(32, 0.0f, false));
                sum += dist2;
                // The engine's tree answers a lower bound past its far
                // thresholds (search.h): below the exact value is allowed.
                bad += (uint64_t)dist2 != (uint64_t)d2[i];
                above += (uint64_t)d2[i] > (uint64_t)dist2;
            }
            const double t = cpu_now() - t0;
            if (t < best) best = t;
        }
        std::printf("nanoflann leaf %-3d %.1f ns/query (best of 3, CPU), build %.2f s, index %.1f "
                    "bytes/particle + 8 x %d coordinates, answers differing from the engine's %zu "
                    "of %zu (engine's above the exact distance: %zu), checksum %.0f\n",
                    leaf, 1e9 * best / (double)nq, tbuild, (double)index.usedMemory(index) / (double)n,
                    DIM, bad, nq, above, sum);
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc < 4) { std::fprintf(stderr, "usage: nn DIM PREFIX LEAF...\n"); return 2; }
    return std::atoi(argv[1]) == 2 ? run<2>(argv[2], argc - 3, argv + 3) : run<3>(argv[2], argc - 3, argv + 3);
}
