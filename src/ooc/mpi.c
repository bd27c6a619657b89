/*
 * The ranks of a distributed job over MPI (comm.h's verbs), for
 * meshreduce-mpi: collectives on MPI_COMM_WORLD's copy, the outcome agreed
 * by a reduction (the lowest failing rank) and that rank's error
 * broadcast, the pieces as plain byte messages. Built only where an MPI
 * implementation is found; the library does not use it.
 */
#include "comm.h"

#include <limits.h>
#include <mpi.h>

typedef struct mpi_impl {
    MPI_Comm comm;
} mpi_impl;

static mr_status mpi_fail(mr_error *err, int code, const char *what)
{
    char text[MPI_MAX_ERROR_STRING];
    int len = 0;
    MPI_Error_string(code, text, &len);
    return mr_fail_plain(err, MR_ERR_IO, NULL, "MPI %s failed: %.*s", what, len, text);
}

static MPI_Datatype mpi_type(ooc_type t, size_t *size)
{
    switch (t) {
    case OOC_U16: *size = 2; return MPI_UINT16_T;
    case OOC_U32: *size = 4; return MPI_UINT32_T;
    case OOC_U64: *size = 8; return MPI_UINT64_T;
    default: *size = 8; return MPI_DOUBLE;
    }
}

static mr_status mpi_reduce(ooc_comm *c, void *data, size_t count, ooc_type type, ooc_op op,
                            mr_error *err)
{
    const mpi_impl *m = c->impl;
    size_t size;
    const MPI_Datatype t = mpi_type(type, &size);
    const MPI_Op o = op == OOC_SUM ? MPI_SUM : op == OOC_MIN ? MPI_MIN : MPI_MAX;
    /* in pieces an int counts */
    for (size_t at = 0; at < count;) {
        const size_t n = count - at < (size_t)(INT_MAX / 8) ? count - at : (size_t)(INT_MAX / 8);
        const int rc = MPI_Allreduce(MPI_IN_PLACE, (char *)data + at * size, (int)n, t, o, m->comm);
        if (rc != MPI_SUCCESS)
            return mpi_fail(err, rc, "Allreduce");
        at += n;
    }
    return MR_OK;
}

static mr_status mpi_gather(ooc_comm *c, const uint64_t *mine, size_t n, uint64_t *all,
                            mr_error *err)
{
    const mpi_impl *m = c->impl;
    if (n > (size_t)INT_MAX)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL, "MPI Allgather: %zu values", n);
    const int rc = MPI_Allgather(mine, (int)n, MPI_UINT64_T, all, (int)n, MPI_UINT64_T, m->comm);
    return rc == MPI_SUCCESS ? MR_OK : mpi_fail(err, rc, "Allgather");
}

static mr_status mpi_agree(ooc_comm *c, mr_status st, mr_error *err)
{
    const mpi_impl *m = c->impl;
    int first = st != MR_OK ? c->rank : c->size;
    int rc = MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_INT, MPI_MIN, m->comm);
    if (rc != MPI_SUCCESS)
        return mpi_fail(err, rc, "Allreduce");
    if (first == c->size)
        return MR_OK;
    /* the first failing rank's status and message, on every rank */
    mr_error e;
    memset(&e, 0, sizeof e);
    if (c->rank == first) {
        if (err)
            e = *err;
        e.status = st;
    }
    rc = MPI_Bcast(&e, (int)sizeof e, MPI_BYTE, first, m->comm);
    if (rc != MPI_SUCCESS)
        return mpi_fail(err, rc, "Bcast");
    if (err)
        *err = e;
    return e.status != MR_OK ? e.status : MR_ERR_IO;
}

static mr_status mpi_send(ooc_comm *c, int to, const void *buf, size_t n, mr_error *err)
{
    const mpi_impl *m = c->impl;
    if (n > (size_t)INT_MAX)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL, "MPI Send: %zu bytes", n);
    const int rc = MPI_Send(buf, (int)n, MPI_BYTE, to, 0, m->comm);
    return rc == MPI_SUCCESS ? MR_OK : mpi_fail(err, rc, "Send");
}

static mr_status mpi_recv(ooc_comm *c, int from, void *buf, size_t n, mr_error *err)
{
    const mpi_impl *m = c->impl;
    if (n > (size_t)INT_MAX)
        return mr_fail_plain(err, MR_ERR_TOO_LARGE, NULL, "MPI Recv: %zu bytes", n);
    MPI_Status status;
    const int rc = MPI_Recv(buf, (int)n, MPI_BYTE, from, 0, m->comm, &status);
    if (rc != MPI_SUCCESS)
        return mpi_fail(err, rc, "Recv");
    int got = 0;
    MPI_Get_count(&status, MPI_BYTE, &got);
    if ((size_t)got != n)
        return mr_fail_plain(err, MR_ERR_IO, NULL, "MPI Recv: %d bytes from rank %d, expected %zu",
                             got, from, n);
    return MR_OK;
}

static mpi_impl world;

void ooc_mpi_comm(ooc_comm *c)
{
    MPI_Comm_dup(MPI_COMM_WORLD, &world.comm);
    /* errors come back as codes (said as the job's error), not abort */
    MPI_Comm_set_errhandler(world.comm, MPI_ERRORS_RETURN);
    MPI_Comm_rank(world.comm, &c->rank);
    MPI_Comm_size(world.comm, &c->size);
    c->impl = &world;
    c->reduce = mpi_reduce;
    c->gather = mpi_gather;
    c->agree = mpi_agree;
    c->send = mpi_send;
    c->recv = mpi_recv;
}

void ooc_mpi_free(ooc_comm *c)
{
    if (c->impl)
        MPI_Comm_free(&world.comm);
    c->impl = NULL;
}
