// Peer driver for bench_simplify: OpenMesh's Decimater with ModQuadric (no
// other module, no error limit) reducing a mesh to a vertex count.
//
//   openmesh_decimate IN OUT VERTICES [RUNS [BUDGET]]
//
// Reads IN (binary PLY or OBJ), then RUNS times (default 1): copies the
// loaded mesh, decimates the copy to VERTICES vertices and garbage-collects
// it; with BUDGET (seconds), stops repeating once the timed runs add up to
// more than that (at least one run). Writes the last result to OUT (binary PLY when OUT ends in .ply).
// File I/O and the copy are not timed. Prints, one per line:
//   input V F          the mesh as OpenMesh read it
//   seconds S          one line per run: decimater setup + decimate_to +
//                      garbage_collection
//   peak_bytes B       first run only: the growth of the peak resident set
//                      (VmHWM) over the resident set after the copy, after
//                      resetting the peak through /proc/self/clear_refs;
//                      -1 when that reset is not available
//   output V F
// Exit status 0 on success.
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

typedef OpenMesh::TriMesh_ArrayKernelT<> Mesh;

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
    if (argc < 4 || argc > 6) {
        std::fprintf(stderr, "usage: openmesh_decimate IN OUT VERTICES [RUNS [BUDGET]]\n");
        return 2;
    }
    const char *in = argv[1], *out = argv[2];
    size_t target = std::strtoull(argv[3], nullptr, 10);
    int runs = argc > 4 ? std::atoi(argv[4]) : 1;
    if (runs < 1)
        runs = 1;
    double budget = argc > 5 ? std::atof(argv[5]) : 0;
    double spent = 0;

    Mesh original;
    OpenMesh::IO::Options ropt;
    if (!OpenMesh::IO::read_mesh(original, in, ropt)) {
        std::fprintf(stderr, "openmesh_decimate: cannot read %s\n", in);
        return 1;
    }
    std::printf("input %zu %zu\n", original.n_vertices(), original.n_faces());

    Mesh work;
    for (int r = 0; r < runs; r++) {
        work = original;
        long long base = -1;
        if (r == 0 && reset_peak())
            base = status_bytes("VmRSS");
        auto t0 = std::chrono::steady_clock::now();
        {
            OpenMesh::Decimater::DecimaterT<Mesh> dec(work);
            OpenMesh::Decimater::ModQuadricT<Mesh>::Handle quadric;
            dec.add(quadric);
            dec.module(quadric).unset_max_err();
            if (!dec.initialize()) {
                std::fprintf(stderr, "openmesh_decimate: decimater initialisation failed\n");
                return 1;
            }
            dec.decimate_to(target);
            // While the decimater lives: it owns the status flags that
            // mark the removed elements.
            work.garbage_collection();
        }
        auto t1 = std::chrono::steady_clock::now();
        double seconds = std::chrono::duration<double>(t1 - t0).count();
        std::printf("seconds %.9f\n", seconds);
        spent += seconds;
        if (r == 0) {
            long long peak = status_bytes("VmHWM");
            std::printf("peak_bytes %lld\n", base >= 0 && peak >= base ? peak - base : -1LL);
        }
        if (budget > 0 && spent > budget)
            break;
    }

    OpenMesh::IO::Options wopt;
    std::string o(out);
    if (o.size() >= 4 && o.compare(o.size() - 4, 4, ".ply") == 0)
        wopt += OpenMesh::IO::Options::Binary;
    if (!OpenMesh::IO::write_mesh(work, out, wopt)) {
        std::fprintf(stderr, "openmesh_decimate: cannot write %s\n", out);
        return 1;
    }
    std::printf("output %zu %zu\n", work.n_vertices(), work.n_faces());
    return 0;
}
