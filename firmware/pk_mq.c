/*
 * pk_mq.c — fixed-capacity ring of planned blocks (see pk_mq.h).
 */
#include <string.h>
#include "pk_mq.h"

void pk_mq_init(struct pk_mq *q)
{
    q->tail = 0;
    q->count = 0;
    q->pops = 0;
}

uint32_t pk_mq_room(const struct pk_mq *q) { return (uint32_t)PK_MQ_CAP - q->count; }

uint32_t pk_mq_count(const struct pk_mq *q) { return q->count; }

struct pk_block *pk_mq_at(struct pk_mq *q, uint32_t i)
{
    if (i >= q->count)
        return NULL;
    return &q->b[(q->tail + i) % PK_MQ_CAP];
}

struct pk_block *pk_mq_push(struct pk_mq *q)
{
    if (q->count >= PK_MQ_CAP)
        return NULL;
    struct pk_block *b = &q->b[(q->tail + q->count) % PK_MQ_CAP];
    memset(b, 0, sizeof *b);
    q->count++;
    return b;
}

void pk_mq_pop(struct pk_mq *q)
{
    if (q->count == 0)
        return;
    q->tail = (uint16_t)((q->tail + 1u) % PK_MQ_CAP);
    q->count--;
    q->pops++;
}
