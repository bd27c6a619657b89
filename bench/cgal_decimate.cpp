// Peer driver for bench_simplify and the sweep: CGAL's Surface_mesh_simplification
// edge collapse on a Surface_mesh, with the Lindstrom-Turk policy (CGAL's
// default cost and placement) or the Garland-Heckbert plane policies,
// reducing a mesh to an edge count.
//
//   cgal_decimate IN OUT POLICY EDGES [RUNS [BUDGET]]
//
// POLICY is lt or gh. Reads IN (binary PLY, OFF or OBJ), then RUNS times
// (default 1): copies the loaded mesh, collapses edges until fewer than
// EDGES remain (Count_stop_predicate: the callers pass the edge count of
// our output, so the triangle counts match on a closed mesh) and collects
// the garbage; with BUDGET (seconds), stops repeating once the timed runs
// add up to more than that (at least one run). Writes the last result to
// OUT (binary PLY). File I/O and the copy are not timed. Prints, one per
// line, as openmesh_decimate does:
//   input V F          the mesh as CGAL read it
//   seconds S          one line per run: policy set-up + edge_collapse +
//                      collect_garbage
//   peak_bytes B       first run only: the growth of the peak resident set
//                      over the resident set after the copy (-1 when the
//                      peak cannot be reset)
//   output V F
// Exit status 0 on success.
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/GarlandHeckbert_policies.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_cost.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_placement.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>
#include <CGAL/boost/graph/IO/polygon_mesh_io.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>

typedef CGAL::Simple_cartesian<double> Kernel;
typedef CGAL::Surface_mesh<Kernel::Point_3> Mesh;
namespace SMS = CGAL::Surface_mesh_simplification;

// A /proc/self/status field in bytes ("VmRSS", "VmHWM"), or -1.
static long long status_bytes(const char *field)
{
    FILE *f = std::fopen("/proc/self/status", "r");
    if (!f)
        return -1;
    char line[256];
    long long kb = -1;
    size_t n = std::strlen(field);
    while (std::fgets(line, sizeof line, f))
        if (!std::strncmp(line, field, n) && line[n] == ':') {
            kb = std::atoll(line + n + 1);
            break;
        }
    std::fclose(f);
    return kb < 0 ? -1 : kb * 1024;
}

static bool reset_peak()
{
    FILE *f = std::fopen("/proc/self/clear_refs", "w");
    if (!f)
        return false;
    bool ok = std::fputs("5", f) >= 0;
    return std::fclose(f) == 0 && ok;
}

int main(int argc, char **argv)
{
    if (argc < 5 || argc > 7 || (std::strcmp(argv[3], "lt") && std::strcmp(argv[3], "gh"))) {
        std::fprintf(stderr, "usage: cgal_decimate IN OUT lt|gh EDGES [RUNS [BUDGET]]\n");
        return 2;
    }
    const char *in = argv[1], *out = argv[2];
    const bool gh = !std::strcmp(argv[3], "gh");
    const std::size_t target = std::strtoull(argv[4], nullptr, 10);
    int runs = argc > 5 ? std::atoi(argv[5]) : 1;
    if (runs < 1)
        runs = 1;
    const double budget = argc > 6 ? std::atof(argv[6]) : 0;
    double spent = 0;

    Mesh original;
    if (!CGAL::IO::read_polygon_mesh(in, original) || !CGAL::is_triangle_mesh(original)) {
        std::fprintf(stderr, "cgal_decimate: cannot read %s as a triangle mesh\n", in);
        return 1;
    }
    std::printf("input %zu %zu\n", (size_t)original.number_of_vertices(),
                (size_t)original.number_of_faces());

    Mesh work;
    for (int r = 0; r < runs; r++) {
        work = original;
        long long base = -1;
        if (r == 0 && reset_peak())
            base = status_bytes("VmRSS");
        auto t0 = std::chrono::steady_clock::now();
        SMS::Count_stop_predicate<Mesh> stop(target);
        if (gh) {
            typedef SMS::GarlandHeckbert_plane_policies<Mesh, Kernel> Policies;
            Policies policies(work);
            SMS::edge_collapse(work, stop,
                               CGAL::parameters::get_cost(policies.get_cost())
                                   .get_placement(policies.get_placement()));
        } else {
            SMS::edge_collapse(work, stop,
                               CGAL::parameters::get_cost(SMS::LindstromTurk_cost<Mesh>())
                                   .get_placement(SMS::LindstromTurk_placement<Mesh>()));
        }
        work.collect_garbage();
        auto t1 = std::chrono::steady_clock::now();
        const double seconds = std::chrono::duration<double>(t1 - t0).count();
        std::printf("seconds %.9f\n", seconds);
        spent += seconds;
        if (r == 0) {
            const long long peak = status_bytes("VmHWM");
            std::printf("peak_bytes %lld\n", base >= 0 && peak >= base ? peak - base : -1LL);
        }
        if (budget > 0 && spent > budget)
            break;
    }

    std::ofstream os(out, std::ios::binary);
    if (!os || !CGAL::IO::write_PLY(os, work, CGAL::parameters::use_binary_mode(true))) {
        std::fprintf(stderr, "cgal_decimate: cannot write %s\n", out);
        return 1;
    }
    std::printf("output %zu %zu\n", (size_t)work.number_of_vertices(),
                (size_t)work.number_of_faces());
    return 0;
}
