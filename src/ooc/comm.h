/*
 * The ranks of a distributed out-of-core job (comm.h): what the job needs
 * of a message-passing engine, as verbs that mpi.c implements over MPI
 * for meshreduce-mpi. The library itself has no MPI: a job without a
 * comm is one rank. Every rank calls the collective verbs in the same
 * order. Internal.
 */
#ifndef MR_OOC_COMM_H
#define MR_OOC_COMM_H

#include "../core/internal.h"

typedef enum ooc_type { OOC_U16, OOC_U32, OOC_U64, OOC_F64 } ooc_type;
typedef enum ooc_op { OOC_SUM, OOC_MIN, OOC_MAX } ooc_op;

typedef struct ooc_comm ooc_comm;
struct ooc_comm {
    int rank, size;
    void *impl;
    /* count values of every rank combined elementwise, into each rank's */
    mr_status (*reduce)(ooc_comm *c, void *data, size_t count, ooc_type type, ooc_op op,
                        mr_error *err);
    /* each rank's n values, all ranks' in rank order into all (size * n) */
    mr_status (*gather)(ooc_comm *c, const uint64_t *mine, size_t n, uint64_t *all,
                        mr_error *err);
    /* the outcome on every rank: MR_OK when every rank's st is, else the
     * status and the error of the lowest rank that failed */
    mr_status (*agree)(ooc_comm *c, mr_status st, mr_error *err);
    /* n bytes to / from one rank (each send matched by one recv) */
    mr_status (*send)(ooc_comm *c, int to, const void *buf, size_t n, mr_error *err);
    mr_status (*recv)(ooc_comm *c, int from, void *buf, size_t n, mr_error *err);
};

/* The ranks of MPI_COMM_WORLD (mpi.c, in meshreduce-mpi only: after
 * MPI_Init; ooc_mpi_free before MPI_Finalize). */
void ooc_mpi_comm(ooc_comm *c);
void ooc_mpi_free(ooc_comm *c);

/* mr_simplify_file on the ranks of comm (NULL: one rank). Every rank
 * reads its share of the input's passes, simplifies the chunks it owns
 * (a run of leaves, and the nodes above whose first leaf it owns), the
 * tree's levels as supersteps with the results sent up between them;
 * rank 0 writes the output. The same bytes at any rank and thread count,
 * and as one rank's. */
mr_status ooc_simplify_file(const char *in_path, const char *out_path,
                            const mr_simplify_options *options,
                            const mr_out_of_core_options *ooc, const mr_write_options *write,
                            ooc_comm *comm, mr_simplify_file_stats *stats, mr_error *err);

/* mr_cluster_file on the ranks of comm (NULL: one rank): each rank reads
 * its share of the vertex blocks for the box, every vertex block for the
 * cells (summing only those of its cells: a hash of the key shares them
 * out) and its share of the face chunks; rank 0 numbers the cells, adds
 * the survivors' quadrics in the file's order and writes the output. The
 * same bytes at any rank and thread count, and as one rank's. */
mr_status ooc_cluster_file(const char *in_path, const char *out_path,
                           const mr_cluster_options *options, const mr_out_of_core_options *ooc,
                           const mr_write_options *write, ooc_comm *comm,
                           mr_cluster_stats *stats, mr_error *err);

#endif
