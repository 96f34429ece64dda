/* Frame packing / parsing for protocol v1 and the SD-card line format; see frame.h. */
#include "frame.h"

#include "crc16.h"

static void put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}

static void put_u32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

static uint16_t get_u16(const uint8_t *p) { return (uint16_t)(p[0] | ((uint16_t)p[1] << 8)); }

static uint32_t get_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

/* Sync, type, version, seq, t_us: the 10-byte prefix shared by all frame types. */
static void put_prefix(uint8_t *out, uint8_t type, uint16_t seq, uint32_t t_us)
{
    out[0] = BN_SYNC0;
    out[1] = BN_SYNC1;
    out[2] = type;
    out[3] = BN_VERSION;
    put_u16(out + 4, seq);
    put_u32(out + 6, t_us);
}

/* The CRC covers every byte after the sync word up to the CRC field itself. */
static size_t put_crc(uint8_t *out, size_t len)
{
    put_u16(out + len - 2, bn_crc16(out + 2, len - 4));
    return len;
}

size_t bn_pack_sample(uint8_t *out, const bn_sample_t *s)
{
    put_prefix(out, BN_TYPE_SAMPLE, s->seq, s->t_us);
    for (uint8_t i = 0; i < 3; i++) {
        put_u16(out + 10 + 2 * i, (uint16_t)s->acc[i]);
        put_u16(out + 16 + 2 * i, (uint16_t)s->gyro[i]);
    }
    put_u16(out + 22, (uint16_t)s->temp);
    return put_crc(out, BN_SAMPLE_LEN);
}

size_t bn_pack_header(uint8_t *out, const bn_header_t *h)
{
    put_prefix(out, BN_TYPE_HEADER, h->seq, h->t_us);
    out[10] = h->accel_fs;
    out[11] = h->gyro_fs;
    out[12] = h->dlpf;
    out[13] = h->smplrt_div;
    out[14] = h->fw_version[0];
    out[15] = h->fw_version[1];
    out[16] = h->fw_version[2];
    out[17] = h->flags;
    put_u32(out + 18, h->device_id);
    return put_crc(out, BN_HEADER_LEN);
}

size_t bn_pack_status(uint8_t *out, const bn_status_t *st)
{
    put_prefix(out, BN_TYPE_STATUS, st->seq, st->t_us);
    out[10] = st->code;
    out[11] = st->detail;
    put_u16(out + 12, st->value);
    return put_crc(out, BN_STATUS_LEN);
}

size_t bn_frame_len(uint8_t type)
{
    switch (type) {
    case BN_TYPE_SAMPLE: return BN_SAMPLE_LEN;
    case BN_TYPE_HEADER: return BN_HEADER_LEN;
    case BN_TYPE_STATUS: return BN_STATUS_LEN;
    default: return 0;
    }
}

int bn_parse(const uint8_t *buf, size_t len, bn_frame_t *out)
{
    if (len < 1)
        return BN_PARSE_NEED_MORE;
    if (buf[0] != BN_SYNC0)
        return BN_PARSE_BAD_SYNC;
    if (len < 2)
        return BN_PARSE_NEED_MORE;
    if (buf[1] != BN_SYNC1)
        return BN_PARSE_BAD_SYNC;
    if (len < 4)
        return BN_PARSE_NEED_MORE;
    size_t flen = bn_frame_len(buf[2]);
    if (flen == 0 || buf[3] != BN_VERSION)
        return BN_PARSE_BAD_TYPE;
    if (len < flen)
        return BN_PARSE_NEED_MORE;
    if (bn_crc16(buf + 2, flen - 4) != get_u16(buf + flen - 2))
        return BN_PARSE_BAD_CRC;

    out->type = buf[2];
    uint16_t seq = get_u16(buf + 4);
    uint32_t t_us = get_u32(buf + 6);
    if (out->type == BN_TYPE_SAMPLE) {
        bn_sample_t *s = &out->u.sample;
        s->seq = seq;
        s->t_us = t_us;
        for (uint8_t i = 0; i < 3; i++) {
            s->acc[i] = (int16_t)get_u16(buf + 10 + 2 * i);
            s->gyro[i] = (int16_t)get_u16(buf + 16 + 2 * i);
        }
        s->temp = (int16_t)get_u16(buf + 22);
    } else if (out->type == BN_TYPE_HEADER) {
        bn_header_t *h = &out->u.header;
        h->seq = seq;
        h->t_us = t_us;
        h->accel_fs = buf[10];
        h->gyro_fs = buf[11];
        h->dlpf = buf[12];
        h->smplrt_div = buf[13];
        h->fw_version[0] = buf[14];
        h->fw_version[1] = buf[15];
        h->fw_version[2] = buf[16];
        h->flags = buf[17];
        h->device_id = get_u32(buf + 18);
    } else {
        bn_status_t *st = &out->u.status;
        st->seq = seq;
        st->t_us = t_us;
        st->code = buf[10];
        st->detail = buf[11];
        st->value = get_u16(buf + 12);
    }
    return (int)flen;
}

/* ---- SD text lines: hand-rolled decimal formatting (printf costs ~1.5 KB of flash on the AVR) ---- */

static size_t put_udec(char *out, uint32_t v)
{
    char tmp[10];
    size_t n = 0;
    do {
        tmp[n++] = (char)('0' + v % 10u);
        v /= 10u;
    } while (v);
    for (size_t i = 0; i < n; i++)
        out[i] = tmp[n - 1 - i];
    return n;
}

static size_t put_idec(char *out, int16_t v)
{
    if (v < 0) {
        out[0] = '-';
        return 1 + put_udec(out + 1, (uint32_t)(-(int32_t)v));
    }
    return put_udec(out, (uint32_t)v);
}

static size_t put_hex(char *out, uint32_t v, uint8_t digits)
{
    static const char hex[] = "0123456789ABCDEF";
    for (uint8_t i = 0; i < digits; i++)
        out[i] = hex[(v >> (4u * (digits - 1u - i))) & 0xFu];
    return digits;
}

static size_t put_str(char *out, const char *s)
{
    size_t n = 0;
    while (s[n]) {
        out[n] = s[n];
        n++;
    }
    return n;
}

size_t bn_format_sd_line(char *out, const bn_sample_t *s)
{
    size_t n = put_udec(out, s->t_us);
    out[n++] = ',';
    n += put_udec(out + n, s->seq);
    const int16_t *v[7] = {&s->acc[0], &s->acc[1], &s->acc[2], &s->gyro[0], &s->gyro[1], &s->gyro[2], &s->temp};
    for (uint8_t i = 0; i < 7; i++) {
        out[n++] = ',';
        n += put_idec(out + n, *v[i]);
    }
    uint16_t crc = bn_crc16((const uint8_t *)out, n);
    out[n++] = '*';
    n += put_hex(out + n, crc, 4);
    out[n++] = '\n';
    return n;
}

size_t bn_format_sd_header(char *out, const bn_header_t *h)
{
    size_t n = put_str(out, "# bootnav-sd v1 accel_fs=");
    n += put_udec(out + n, h->accel_fs);
    n += put_str(out + n, " gyro_fs=");
    n += put_udec(out + n, h->gyro_fs);
    n += put_str(out + n, " dlpf=");
    n += put_udec(out + n, h->dlpf);
    n += put_str(out + n, " smplrt_div=");
    n += put_udec(out + n, h->smplrt_div);
    n += put_str(out + n, " fw=");
    for (uint8_t i = 0; i < 3; i++) {
        if (i)
            out[n++] = '.';
        n += put_udec(out + n, h->fw_version[i]);
    }
    n += put_str(out + n, " device_id=0x");
    n += put_hex(out + n, h->device_id, 8);
    out[n++] = '\n';
    return n;
}
