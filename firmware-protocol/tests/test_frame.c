/* Host unit tests of the firmware's frame, CRC and SD-log code (firmware/bootnav_imu/{frame,crc16,sdlog}.c)
 * against the shared protocol vectors in test-vectors/vectors.txt, the same vectors the Python side
 * (bootnav.logger.protocol) is tested with. Built and run by `make -C firmware-protocol test`.
 *
 * Vector kinds (format: the header of vectors.txt):
 *   crc     bn_crc16 of the bytes equals crc=
 *   frame   bn_parse decodes every field as listed, and bn_pack_* of those fields gives the same bytes
 *   stream  scanning with bn_parse and a one-byte resync finds exactly frames= at offsets= with
 *           types= and seqs=
 *   sdline  ok=1: bn_format_sd_line of values= reproduces the line byte for byte (when the values fit
 *           the firmware's field types); ok=0 error=CRC: the CRC over the text before '*' differs
 * plus self-contained checks: round trips, every single-bit flip detected, SD-log buffering and
 * card-full handling. */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crc16.h"
#include "frame.h"
#include "sdlog.h"

static int g_pass, g_fail;

#define CHECK(cond, ...)                                                                                     \
    do {                                                                                                     \
        if (cond) {                                                                                          \
            g_pass++;                                                                                        \
        } else {                                                                                             \
            g_fail++;                                                                                        \
            printf("FAIL %s:%d: ", __FILE__, __LINE__);                                                      \
            printf(__VA_ARGS__);                                                                             \
            printf("\n");                                                                                    \
        }                                                                                                    \
    } while (0)

/* ------------------------------------------------------------------ vector-line helpers */

static size_t unhex(const char *hex, uint8_t *out, size_t cap)
{
    if (strcmp(hex, "-") == 0)
        return 0;
    size_t n = strlen(hex) / 2;
    if (n > cap) {
        printf("vector too long (%zu bytes)\n", n);
        exit(2);
    }
    for (size_t i = 0; i < n; i++) {
        unsigned v;
        sscanf(hex + 2 * i, "%2x", &v);
        out[i] = (uint8_t)v;
    }
    return n;
}

/* Value of key= among the tokens, or NULL. */
static const char *kv(char **tok, int ntok, const char *key)
{
    size_t k = strlen(key);
    for (int i = 0; i < ntok; i++)
        if (strncmp(tok[i], key, k) == 0 && tok[i][k] == '=')
            return tok[i] + k + 1;
    return NULL;
}

/* Parse a comma-separated integer list ('-' = empty) into out; return the count. */
static int ints(const char *s, long long *out, int cap)
{
    if (!s || strcmp(s, "-") == 0)
        return 0;
    int n = 0;
    while (*s && n < cap) {
        char *end;
        out[n++] = strtoll(s, &end, 0);
        s = (*end == ',') ? end + 1 : end;
        if (end == s && *s != ',')
            break;
    }
    return n;
}

static long long ival(char **tok, int ntok, const char *key)
{
    const char *v = kv(tok, ntok, key);
    if (!v) {
        printf("vector lacks %s=\n", key);
        g_fail++;
        return 0;
    }
    return strtoll(v, NULL, 0);
}

/* ------------------------------------------------------------------ vector kinds */

static void vec_crc(const char *name, const char *hex, char **tok, int ntok)
{
    uint8_t buf[512];
    size_t n = unhex(hex, buf, sizeof buf);
    unsigned want = (unsigned)strtoul(kv(tok, ntok, "crc"), NULL, 16);
    unsigned got = bn_crc16(buf, n);
    CHECK(got == want, "%s: crc %04X, expected %04X", name, got, want);
}

static void vec_frame(const char *name, const char *hex, char **tok, int ntok)
{
    uint8_t buf[64], packed[64];
    size_t n = unhex(hex, buf, sizeof buf);
    bn_frame_t f;
    int r = bn_parse(buf, n, &f);
    CHECK(r == (int)n, "%s: bn_parse returned %d for a %zu-byte frame", name, r, n);
    if (r != (int)n)
        return;
    long long type = ival(tok, ntok, "type");
    CHECK(f.type == type, "%s: type %u, expected %lld", name, f.type, type);
    long long l[8];
    size_t plen = 0;
    if (f.type == BN_TYPE_SAMPLE) {
        bn_sample_t e;
        e.seq = (uint16_t)ival(tok, ntok, "seq");
        e.t_us = (uint32_t)ival(tok, ntok, "t_us");
        CHECK(ints(kv(tok, ntok, "acc"), l, 8) == 3, "%s: acc list", name);
        for (int i = 0; i < 3; i++)
            e.acc[i] = (int16_t)l[i];
        CHECK(ints(kv(tok, ntok, "gyro"), l, 8) == 3, "%s: gyro list", name);
        for (int i = 0; i < 3; i++)
            e.gyro[i] = (int16_t)l[i];
        e.temp = (int16_t)ival(tok, ntok, "temp");
        const bn_sample_t *s = &f.u.sample;
        CHECK(s->seq == e.seq && s->t_us == e.t_us && s->temp == e.temp &&
                  !memcmp(s->acc, e.acc, sizeof e.acc) && !memcmp(s->gyro, e.gyro, sizeof e.gyro),
              "%s: decoded sample fields differ", name);
        plen = bn_pack_sample(packed, &e);
    } else if (f.type == BN_TYPE_HEADER) {
        bn_header_t e;
        e.seq = (uint16_t)ival(tok, ntok, "seq");
        e.t_us = (uint32_t)ival(tok, ntok, "t_us");
        e.accel_fs = (uint8_t)ival(tok, ntok, "accel_fs");
        e.gyro_fs = (uint8_t)ival(tok, ntok, "gyro_fs");
        e.dlpf = (uint8_t)ival(tok, ntok, "dlpf");
        e.smplrt_div = (uint8_t)ival(tok, ntok, "smplrt_div");
        CHECK(ints(kv(tok, ntok, "fw_version"), l, 8) == 3, "%s: fw_version list", name);
        for (int i = 0; i < 3; i++)
            e.fw_version[i] = (uint8_t)l[i];
        e.flags = (uint8_t)ival(tok, ntok, "flags");
        e.device_id = (uint32_t)ival(tok, ntok, "device_id");
        const bn_header_t *h = &f.u.header;
        CHECK(h->seq == e.seq && h->t_us == e.t_us && h->accel_fs == e.accel_fs && h->gyro_fs == e.gyro_fs &&
                  h->dlpf == e.dlpf && h->smplrt_div == e.smplrt_div &&
                  !memcmp(h->fw_version, e.fw_version, 3) && h->flags == e.flags && h->device_id == e.device_id,
              "%s: decoded header fields differ", name);
        plen = bn_pack_header(packed, &e);
    } else {
        bn_status_t e;
        e.seq = (uint16_t)ival(tok, ntok, "seq");
        e.t_us = (uint32_t)ival(tok, ntok, "t_us");
        e.code = (uint8_t)ival(tok, ntok, "code");
        e.detail = (uint8_t)ival(tok, ntok, "detail");
        e.value = (uint16_t)ival(tok, ntok, "value");
        const bn_status_t *st = &f.u.status;
        CHECK(st->seq == e.seq && st->t_us == e.t_us && st->code == e.code && st->detail == e.detail &&
                  st->value == e.value,
              "%s: decoded status fields differ", name);
        plen = bn_pack_status(packed, &e);
    }
    CHECK(plen == n && memcmp(packed, buf, n) == 0, "%s: packing the listed fields does not give the vector bytes",
          name);
}

static void vec_stream(const char *name, const char *hex, char **tok, int ntok)
{
    static uint8_t buf[4096];
    size_t n = unhex(hex, buf, sizeof buf);
    long long types[64], offsets[64], seqs[64];
    int nf = 0;
    size_t pos = 0;
    while (pos < n && nf < 64) {
        bn_frame_t f;
        int r = bn_parse(buf + pos, n - pos, &f);
        if (r == BN_PARSE_NEED_MORE)
            break; /* truncated tail */
        if (r < 0) {
            pos++; /* resync: skip one byte, look for the next sync word */
            continue;
        }
        types[nf] = f.type;
        offsets[nf] = (long long)pos;
        seqs[nf] = f.type == BN_TYPE_SAMPLE ? f.u.sample.seq
                   : f.type == BN_TYPE_HEADER ? f.u.header.seq
                                              : f.u.status.seq;
        nf++;
        pos += (size_t)r;
    }
    long long want[64];
    long long want_n = ival(tok, ntok, "frames");
    CHECK(nf == want_n, "%s: %d frames, expected %lld", name, nf, want_n);
    if (nf != want_n)
        return;
    int k = ints(kv(tok, ntok, "types"), want, 64);
    CHECK(k == nf && !memcmp(want, types, sizeof(long long) * (size_t)nf), "%s: frame types differ", name);
    k = ints(kv(tok, ntok, "offsets"), want, 64);
    CHECK(k == nf && !memcmp(want, offsets, sizeof(long long) * (size_t)nf), "%s: frame offsets differ", name);
    k = ints(kv(tok, ntok, "seqs"), want, 64);
    CHECK(k == nf && !memcmp(want, seqs, sizeof(long long) * (size_t)nf), "%s: seqs differ", name);
}

static int g_sd_out_of_range;

static void vec_sdline(const char *name, const char *line, char **tok, int ntok)
{
    const char *ok = kv(tok, ntok, "ok");
    if (ok && strcmp(ok, "1") == 0) {
        long long v[9];
        CHECK(ints(kv(tok, ntok, "values"), v, 9) == 9, "%s: values list", name);
        int fits = v[0] >= 0 && v[0] <= 0xFFFFFFFFLL && v[1] >= 0 && v[1] <= 0xFFFF;
        for (int i = 2; i < 9; i++)
            fits &= v[i] >= -32768 && v[i] <= 32767;
        if (!fits) { /* a line the logger accepts but this firmware cannot produce */
            g_sd_out_of_range++;
            return;
        }
        bn_sample_t s = {(uint16_t)v[1], (uint32_t)v[0], {(int16_t)v[2], (int16_t)v[3], (int16_t)v[4]},
                         {(int16_t)v[5], (int16_t)v[6], (int16_t)v[7]}, (int16_t)v[8]};
        char out[BN_SD_LINE_MAX + 1];
        size_t n = bn_format_sd_line(out, &s);
        CHECK(n <= BN_SD_LINE_MAX && out[n - 1] == '\n', "%s: line length %zu", name, n);
        out[n - 1] = 0;
        CHECK(strcmp(out, line) == 0, "%s: formatted '%s', expected '%s'", name, out, line);
    } else {
        const char *err = kv(tok, ntok, "error");
        const char *star = strchr(line, '*');
        if (err && strcmp(err, "CRC") == 0 && star) {
            unsigned stated = (unsigned)strtoul(star + 1, NULL, 16);
            unsigned got = bn_crc16((const uint8_t *)line, (size_t)(star - line));
            CHECK(got != stated, "%s: CRC of the text matches although the vector says it must not", name);
        }
    }
}

static int run_vectors(const char *dir)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/vectors.txt", dir);
    FILE *f = fopen(path, "r");
    if (!f) {
        printf("FAIL: cannot open %s (the shared protocol test vectors)\n", path);
        g_fail++;
        return 0;
    }
    static char line[16384];
    int count[4] = {0};
    while (fgets(line, sizeof line, f)) {
        line[strcspn(line, "\r\n")] = 0;
        if (line[0] == '#' || line[0] == 0)
            continue;
        char *tok[64];
        int ntok = 0;
        for (char *t = strtok(line, " "); t && ntok < 64; t = strtok(NULL, " "))
            tok[ntok++] = t;
        if (ntok < 3)
            continue;
        if (!strcmp(tok[0], "crc"))
            vec_crc(tok[1], tok[2], tok + 3, ntok - 3), count[0]++;
        else if (!strcmp(tok[0], "frame"))
            vec_frame(tok[1], tok[2], tok + 3, ntok - 3), count[1]++;
        else if (!strcmp(tok[0], "stream"))
            vec_stream(tok[1], tok[2], tok + 3, ntok - 3), count[2]++;
        else if (!strcmp(tok[0], "sdline"))
            vec_sdline(tok[1], tok[2], tok + 3, ntok - 3), count[3]++;
    }
    fclose(f);
    printf("vectors: %d crc, %d frame, %d stream, %d sdline (%d sdline values outside the firmware's u32/u16/i16 "
           "fields: not formatted)\n",
           count[0], count[1], count[2], count[3], g_sd_out_of_range);
    CHECK(count[0] > 0 && count[1] > 0 && count[2] > 0, "%s holds no crc/frame/stream vectors", path);
    return count[0] + count[1] + count[2] + count[3];
}

/* ------------------------------------------------------------------ self-contained checks */

static uint32_t g_rng = 12345u; /* fixed seed: deterministic */
static uint32_t rnd(void)
{
    g_rng = g_rng * 1664525u + 1013904223u;
    return g_rng;
}

static void test_crc_catalogue(void)
{
    CHECK(bn_crc16((const uint8_t *)"123456789", 9) == 0x29B1, "check value of '123456789' is not 0x29B1");
    uint16_t c = BN_CRC16_INIT;
    for (const char *p = "123456789"; *p; p++)
        c = bn_crc16_update(c, (uint8_t)*p);
    CHECK(c == 0x29B1, "byte-wise CRC differs from buffer CRC");
}

static void test_round_trip_and_bit_flips(void)
{
    int undetected = 0, bad_round_trip = 0;
    for (int k = 0; k < 200; k++) {
        bn_sample_t s;
        s.seq = (uint16_t)rnd();
        s.t_us = rnd();
        for (int i = 0; i < 3; i++) {
            s.acc[i] = (int16_t)rnd();
            s.gyro[i] = (int16_t)rnd();
        }
        s.temp = (int16_t)rnd();
        uint8_t buf[BN_SAMPLE_LEN];
        bn_frame_t f;
        size_t n = bn_pack_sample(buf, &s);
        if (n != BN_SAMPLE_LEN || bn_parse(buf, n, &f) != (int)n || memcmp(&f.u.sample, &s, sizeof s) != 0)
            bad_round_trip++;
        /* CRC-16 detects every single-bit error: no flipped frame may decode */
        for (size_t bit = 0; bit < 8 * n; bit++) {
            buf[bit / 8] ^= (uint8_t)(1u << (bit % 8));
            if (bn_parse(buf, n, &f) > 0)
                undetected++;
            buf[bit / 8] ^= (uint8_t)(1u << (bit % 8));
        }
    }
    CHECK(bad_round_trip == 0, "%d sample frames did not survive pack/parse", bad_round_trip);
    CHECK(undetected == 0, "%d single-bit flips went undetected", undetected);

    bn_status_t st = {7, 123456u, BN_STATUS_OVERRUN, 0, 3};
    uint8_t sb[BN_STATUS_LEN];
    bn_frame_t f;
    CHECK(bn_pack_status(sb, &st) == BN_STATUS_LEN && bn_parse(sb, BN_STATUS_LEN, &f) == BN_STATUS_LEN &&
              f.type == BN_TYPE_STATUS && f.u.status.value == 3 && f.u.status.t_us == 123456u,
          "status frame round trip");
    CHECK(bn_parse(sb, BN_STATUS_LEN - 1, &f) == BN_PARSE_NEED_MORE, "short status frame must ask for more");
}

static void test_sd_line_extremes(void)
{
    bn_sample_t s = {65535, 4294967295u, {-32768, -32768, -32768}, {-32768, -32768, -32768}, -32768};
    char out[BN_SD_LINE_MAX + 8];
    memset(out, '#', sizeof out);
    size_t n = bn_format_sd_line(out, &s);
    CHECK(n == BN_SD_LINE_MAX - 1, "longest SD line is %zu characters, expected %u", n, BN_SD_LINE_MAX - 1);
    CHECK(out[n] == '#', "SD line formatter wrote past the returned length");
    const char *want = "4294967295,65535,-32768,-32768,-32768,-32768,-32768,-32768,-32768*";
    CHECK(strncmp(out, want, strlen(want)) == 0, "extreme SD line text");

    bn_header_t h = {0, 0, 3, 3, 3, 4, {0, 1, 0}, 0, 0x0000BEEFu};
    char hb[BN_SD_HEADER_MAX];
    size_t hn = bn_format_sd_header(hb, &h);
    const char *hw = "# bootnav-sd v1 accel_fs=3 gyro_fs=3 dlpf=3 smplrt_div=4 fw=0.1.0 device_id=0x0000BEEF\n";
    CHECK(hn == strlen(hw) && memcmp(hb, hw, hn) == 0, "SD header line differs from PROTOCOL.md section 2");
}

/* A RAM "card" with a capacity: stands in for the SD library in the sink interface. */
typedef struct {
    uint8_t data[4096];
    uint16_t used, capacity;
    int writes, flushes, fail_flush;
} ram_card_t;

static uint16_t ram_write(void *ctx, const uint8_t *d, uint16_t len)
{
    ram_card_t *c = ctx;
    c->writes++;
    uint16_t room = (uint16_t)(c->capacity - c->used);
    uint16_t n = len < room ? len : room;
    memcpy(c->data + c->used, d, n);
    c->used = (uint16_t)(c->used + n);
    return n;
}

static uint8_t ram_flush(void *ctx)
{
    ram_card_t *c = ctx;
    c->flushes++;
    return !c->fail_flush;
}

static void test_sdlog(void)
{
    static ram_card_t card;
    memset(&card, 0, sizeof card);
    card.capacity = sizeof card.data;
    bn_sd_sink_t sink = {ram_write, ram_flush, &card};
    bn_sdlog_t log;
    bn_sdlog_init(&log, &sink);
    static char expect[8192];
    size_t elen = 0;
    for (int i = 0; i < 40; i++) {
        bn_sample_t s = {(uint16_t)i, 5000u * (uint32_t)i, {(int16_t)i, -1, 2048}, {3, -4, 5}, -3920};
        char line[BN_SD_LINE_MAX];
        size_t n = bn_format_sd_line(line, &s);
        memcpy(expect + elen, line, n);
        elen += n;
        CHECK(bn_sdlog_append(&log, line, (uint16_t)n) == 0, "append %d reported a failure", i);
    }
    CHECK(card.writes > 0 && card.writes < 40, "lines must reach the card in buffered chunks (%d writes)", card.writes);
    CHECK(bn_sdlog_flush(&log) == 0 && card.flushes == 1, "flush");
    CHECK(card.used == elen && memcmp(card.data, expect, elen) == 0, "card content differs from the lines");

    /* A card that fills up: the failure is reported exactly once and every line not stored is counted. */
    memset(&card, 0, sizeof card);
    card.capacity = 300;
    bn_sdlog_init(&log, &sink);
    int reports = 0, lines = 0;
    size_t total = 0;
    for (int i = 0; i < 30; i++) {
        bn_sample_t s = {(uint16_t)i, 1000u + (uint32_t)i, {1, 2, 3}, {4, 5, 6}, 7};
        char line[BN_SD_LINE_MAX];
        size_t n = bn_format_sd_line(line, &s);
        total += n;
        lines++;
        reports += bn_sdlog_append(&log, line, (uint16_t)n);
    }
    reports += bn_sdlog_flush(&log);
    int stored_lines = 0;
    for (int i = 0; i < card.used; i++)
        stored_lines += card.data[i] == '\n';
    CHECK(reports == 1, "card-full reported %d times, expected once", reports);
    CHECK(log.failed == 1, "log not marked failed");
    CHECK(stored_lines + log.lost == lines, "stored %d + lost %u != %d lines", stored_lines, log.lost, lines);
    CHECK(card.used == 300, "card not filled to capacity (%u)", card.used);

    /* A flush the card rejects is a failure too. */
    memset(&card, 0, sizeof card);
    card.capacity = sizeof card.data;
    card.fail_flush = 1;
    bn_sdlog_init(&log, &sink);
    CHECK(bn_sdlog_append(&log, "x\n", 2) == 0 && bn_sdlog_flush(&log) == 1 && log.failed, "rejected flush");
}

int main(int argc, char **argv)
{
    const char *dir = argc > 1 ? argv[1] : "test-vectors";
    test_crc_catalogue();
    test_round_trip_and_bit_flips();
    test_sd_line_extremes();
    test_sdlog();
    run_vectors(dir);
    printf("%d passed, %d failed\n", g_pass, g_fail);
    return g_fail ? 1 : 0;
}
