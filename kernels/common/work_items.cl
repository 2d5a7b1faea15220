/*
 * work_items.cl - how the sampling kernels split their work: global id g = (item * replicates +
 * replicate) * chunks + chunk, each replicate's points cut into `chunks` equal runs so that small
 * batches still fill a device (the host sums the chunks' tallies, in this same order).
 */
typedef struct ms_work_item {
    uint item;      /* the query, texel or target */
    uint replicate;
    uint first;     /* first point of the run, in the replicate-major point set */
    uint count;     /* points in the run */
} ms_work_item;

inline ms_work_item ms_work_item_of(uint g, uint replicates, uint chunks, uint points_per_replicate)
{
    ms_work_item w;
    const uint chunk = g % chunks;
    w.replicate = (g / chunks) % replicates;
    w.item = g / (chunks * replicates);
    w.count = points_per_replicate / chunks;
    w.first = w.replicate * points_per_replicate + chunk * w.count;
    return w;
}
