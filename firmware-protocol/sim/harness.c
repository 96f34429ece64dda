/* bootnav firmware simulation harness (libsimavr).
 *
 * Runs the bootnav_imu firmware on a simulated ATmega328P at 16 MHz and connects it to
 *   - an MPU6050 model on the TWI bus (I2C address 0x68): register file, WHO_AM_I, reset, sleep,
 *     auto-incrementing register pointer, big-endian data registers, and a data-ready pulse on the INT
 *     pin (D2 / INT0) at the rate the firmware programmed (SMPLRT_DIV, DLPF_CFG), each pulse latching
 *     the next sample of a sample file into ACCEL_XOUT_H..GYRO_ZOUT_L;
 *   - a pseudo-terminal bridged to UART0, so a host program (bootnav record, pyserial) talks to the
 *     simulated board exactly as to a USB serial port.
 *
 * Sample file: raw little-endian int16 records of 7 values in frame order ax ay az gx gy gz temp
 * (MPU6050 counts). When the file is exhausted the model stops pulsing INT (a sensor that went quiet).
 *
 * Usage: harness --firmware F.elf --samples S.bin [--wait-open] [--realtime] [--idle-when-done]
 *                [--whoami 0x68] [--absent] [--stats FILE.json] [--max-seconds N]
 *   --wait-open       hold the board in reset until a host opens the pty, then start it 100 ms later
 *                     (like a Nano's auto-reset on DTR; also keeps the start-up frames away from the
 *                     input flush a serial library does right after opening)
 *   --realtime        never run ahead of the wall clock (default: as fast as the host CPU allows)
 *   --idle-when-done  stop the CPU 0.2 s (simulated) after the last sample was served and sent, but
 *                     keep the pty open: saves the host CPU while a recorder finishes; prints "idle"
 *   --burst-at K      after sample K, two more samples 60 us and 120 us later (faster than the firmware
 *                     reads): tests the overrun report
 *   --brownout-at K   one period after sample K the model resets to its power-on state (a supply
 *                     dip): tests that the firmware notices the silence and re-initialises it
 *   --whoami V        WHO_AM_I value of the model (a clone or a wrong chip); --absent: no device at 0x68
 * Prints "pty /dev/pts/N" on stdout (libsimavr prints its own "Loaded ..." lines there too). Exits
 * when the host closes the pty after having opened it, on SIGTERM/SIGINT, or after --max-seconds of
 * wall time; writes counters to --stats as JSON.
 *
 * Written for bootnav against the public libsimavr API (sim_avr.h, avr_twi.h, avr_uart.h,
 * avr_ioport.h); no code from simavr's examples. */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "avr_ioport.h"
#include "avr_twi.h"
#include "avr_uart.h"
#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_irq.h"
#include "sim_time.h"

#define F_CPU_HZ 16000000u
#define INT_PULSE_US 50u /* MPU6050 INT_PIN_CFG LATCH_INT_EN = 0: 50 us pulse */

/* ---------------------------------------------------------------- MPU6050 model */

enum {
    REG_SMPLRT_DIV = 0x19,
    REG_CONFIG = 0x1A,
    REG_INT_PIN_CFG = 0x37,
    REG_INT_ENABLE = 0x38,
    REG_INT_STATUS = 0x3A,
    REG_ACCEL_XOUT_H = 0x3B,
    REG_GYRO_ZOUT_L = 0x48,
    REG_PWR_MGMT_1 = 0x6B,
    REG_WHO_AM_I = 0x75,
    REG_FIFO_EN = 0x23,
    REG_USER_CTRL = 0x6A,
    REG_FIFO_COUNTH = 0x72,
    REG_FIFO_COUNTL = 0x73,
    REG_FIFO_R_W = 0x74,
};

#define FIFO_SIZE 1024u

typedef struct {
    avr_t *avr;
    avr_irq_t *twi_in;   /* replies to the AVR's TWI master */
    avr_irq_t *int_pin;  /* PD2 */
    uint8_t addr;        /* 7-bit */
    uint8_t present;
    uint8_t whoami;
    uint8_t reg[128];
    uint8_t fifo[FIFO_SIZE]; /* ring: fifo_head = oldest byte */
    uint16_t fifo_head, fifo_count, fifo_count_latched;
    uint32_t fifo_overflows;
    uint8_t ptr;         /* register pointer */
    uint8_t selected;    /* addressed in the current transaction */
    uint8_t expect_ptr;  /* next written byte sets the register pointer */
    uint8_t ticking;     /* data-ready timer armed */
    const int16_t *samples; /* n_samples x 7 */
    size_t n_samples;
    size_t served;
    int16_t held[7];     /* sample that arrived during a bus transaction, latched at STOP */
    uint8_t has_held;
    size_t burst_at;     /* --burst-at: after serving this index, two extra samples 60 us apart */
    uint8_t burst_left;
    size_t brownout_at;  /* --brownout-at: power-on reset one period after serving this index */
    uint8_t browned_out;
    avr_cycle_count_t first_drdy_cycle;
    avr_cycle_count_t period_cycles;
    uint32_t reg_writes;
} mpu_t;

static void mpu_reset_regs(mpu_t *m)
{
    memset(m->reg, 0, sizeof m->reg);
    m->fifo_head = m->fifo_count = 0;
    m->reg[REG_PWR_MGMT_1] = 0x40; /* SLEEP after power-up / reset */
    m->reg[REG_WHO_AM_I] = m->whoami;
}

/* Data-ready period in CPU cycles: gyro output rate / (1 + SMPLRT_DIV); the output rate is 8 kHz with
 * the DLPF off (DLPF_CFG 0 or 7) and 1 kHz otherwise (register map rev 4.2, section 4.2). */
static avr_cycle_count_t mpu_period_cycles(const mpu_t *m)
{
    uint8_t dlpf = m->reg[REG_CONFIG] & 0x07;
    uint32_t base_hz = (dlpf == 0 || dlpf == 7) ? 8000u : 1000u;
    return (avr_cycle_count_t)F_CPU_HZ * (1u + m->reg[REG_SMPLRT_DIV]) / base_hz;
}

static int mpu_running(const mpu_t *m)
{
    return !(m->reg[REG_PWR_MGMT_1] & 0x40) && (m->reg[REG_INT_ENABLE] & 0x01);
}

static void put_be16(uint8_t *p, int16_t v)
{
    p[0] = (uint8_t)((uint16_t)v >> 8);
    p[1] = (uint8_t)v;
}

static avr_cycle_count_t int_pin_low(avr_t *avr, avr_cycle_count_t when, void *param)
{
    (void)avr;
    (void)when;
    mpu_t *m = param;
    int active_low = (m->reg[REG_INT_PIN_CFG] & 0x80) != 0;
    avr_raise_irq(m->int_pin, active_low ? 1 : 0);
    return 0;
}

/* ACCEL_XOUT_H..GYRO_ZOUT_L from one file record (ax ay az gx gy gz temp -> ACCEL X..Z, TEMP, GYRO X..Z). */
static void mpu_latch(mpu_t *m, const int16_t *s)
{
    uint8_t *r = m->reg + REG_ACCEL_XOUT_H;
    put_be16(r + 0, s[0]);
    put_be16(r + 2, s[1]);
    put_be16(r + 4, s[2]);
    put_be16(r + 6, s[6]);
    put_be16(r + 8, s[3]);
    put_be16(r + 10, s[4]);
    put_be16(r + 12, s[5]);
}

/* FIFO (register map 4.6, 4.17, 4.30-4.32): with USER_CTRL.FIFO_EN each sample appends the sensors
 * selected in FIFO_EN, in register order (accel X..Z, temp, gyro X..Z, big-endian); when full the
 * oldest byte is overwritten and INT_STATUS.FIFO_OFLOW_INT is set. */
static void fifo_push(mpu_t *m, uint8_t b)
{
    if (m->fifo_count == FIFO_SIZE) {
        m->fifo_head = (uint16_t)((m->fifo_head + 1) % FIFO_SIZE);
        m->fifo_count--;
        m->reg[REG_INT_STATUS] |= 0x10;
        m->fifo_overflows++;
    }
    m->fifo[(m->fifo_head + m->fifo_count) % FIFO_SIZE] = b;
    m->fifo_count++;
}

static void fifo_push16(mpu_t *m, int16_t v)
{
    fifo_push(m, (uint8_t)((uint16_t)v >> 8));
    fifo_push(m, (uint8_t)v);
}

static void fifo_sample(mpu_t *m, const int16_t *s)
{
    uint8_t en = m->reg[REG_FIFO_EN];
    if (!(m->reg[REG_USER_CTRL] & 0x40))
        return;
    if (en & 0x08) { /* ACCEL_FIFO_EN */
        fifo_push16(m, s[0]);
        fifo_push16(m, s[1]);
        fifo_push16(m, s[2]);
    }
    if (en & 0x80) /* TEMP_FIFO_EN */
        fifo_push16(m, s[6]);
    if (en & 0x40)
        fifo_push16(m, s[3]);
    if (en & 0x20)
        fifo_push16(m, s[4]);
    if (en & 0x10)
        fifo_push16(m, s[5]);
}

/* A new sample: into the FIFO (if enabled) and the data registers, or held while the bus is busy (the MPU6050 updates its
 * registers only while the serial interface is idle, so a burst read is always one coherent sample);
 * then the INT pulse. */
static void mpu_new_sample(mpu_t *m, avr_cycle_count_t when)
{
    const int16_t *s = m->samples + 7 * m->served;
    fifo_sample(m, s);
    if (m->selected) {
        memcpy(m->held, s, sizeof m->held);
        m->has_held = 1;
    } else {
        mpu_latch(m, s);
    }
    if (m->served == 0)
        m->first_drdy_cycle = when;
    m->served++;
    m->reg[REG_INT_STATUS] |= 0x01; /* DATA_RDY_INT */
    int active_low = (m->reg[REG_INT_PIN_CFG] & 0x80) != 0;
    avr_raise_irq(m->int_pin, active_low ? 0 : 1);
    avr_cycle_timer_register_usec(m->avr, INT_PULSE_US, int_pin_low, m);
}

/* --burst-at: extra samples 60 us apart, faster than the firmware can read them (a stalled main loop
 * on real hardware): the firmware must report the one it missed as an overrun. */
static avr_cycle_count_t mpu_burst(avr_t *avr, avr_cycle_count_t when, void *param)
{
    mpu_t *m = param;
    if (!m->burst_left || m->served >= m->n_samples)
        return 0;
    mpu_new_sample(m, when);
    return --m->burst_left ? when + avr_usec_to_cycles(avr, 60) : 0;
}

static avr_cycle_count_t mpu_data_ready(avr_t *avr, avr_cycle_count_t when, void *param)
{
    mpu_t *m = param;
    if (!mpu_running(m) || m->served >= m->n_samples) {
        m->ticking = 0;
        return 0;
    }
    if (!m->browned_out && m->served > 0 && m->served - 1 == m->brownout_at) {
        /* supply dip: the chip resets to its power-on state (asleep, data-ready off) */
        m->browned_out = 1;
        mpu_reset_regs(m);
        m->ticking = 0;
        return 0;
    }
    mpu_new_sample(m, when);
    if (m->served - 1 == m->burst_at) {
        m->burst_left = 2;
        avr_cycle_timer_register_usec(avr, 60, mpu_burst, m);
    }
    m->period_cycles = mpu_period_cycles(m);
    return when + m->period_cycles;
}

static void mpu_update_timer(mpu_t *m)
{
    if (mpu_running(m) && !m->ticking && m->served < m->n_samples) {
        m->ticking = 1;
        m->period_cycles = mpu_period_cycles(m);
        avr_cycle_timer_register(m->avr, m->period_cycles, mpu_data_ready, m);
    } else if (!mpu_running(m) && m->ticking) {
        avr_cycle_timer_cancel(m->avr, mpu_data_ready, m);
        m->ticking = 0;
    }
}

static void mpu_write(mpu_t *m, uint8_t reg, uint8_t v)
{
    m->reg_writes++;
    if (reg >= 128 || (reg >= REG_ACCEL_XOUT_H && reg <= REG_GYRO_ZOUT_L) || reg == REG_WHO_AM_I ||
        reg == REG_INT_STATUS)
        return; /* read-only */
    if (reg == REG_PWR_MGMT_1 && (v & 0x80)) {
        mpu_reset_regs(m); /* DEVICE_RESET: registers back to defaults, bit clears itself */
    } else if (reg == REG_USER_CTRL) {
        if (v & 0x04) /* FIFO_RESET, clears itself */
            m->fifo_head = m->fifo_count = 0;
        m->reg[reg] = v & (uint8_t)~0x07;
    } else {
        m->reg[reg] = v;
    }
    mpu_update_timer(m);
}

static uint8_t mpu_read(mpu_t *m, uint8_t reg)
{
    if (reg >= 128)
        return 0xFF;
    if (reg == REG_FIFO_COUNTH) { /* the count is latched when its high byte is read */
        m->fifo_count_latched = m->fifo_count;
        return (uint8_t)(m->fifo_count_latched >> 8);
    }
    if (reg == REG_FIFO_COUNTL)
        return (uint8_t)m->fifo_count_latched;
    if (reg == REG_FIFO_R_W) {
        if (!m->fifo_count)
            return 0;
        uint8_t b = m->fifo[m->fifo_head];
        m->fifo_head = (uint16_t)((m->fifo_head + 1) % FIFO_SIZE);
        m->fifo_count--;
        return b;
    }
    uint8_t v = m->reg[reg];
    if (reg == REG_INT_STATUS)
        m->reg[REG_INT_STATUS] = 0; /* cleared by reading */
    return v;
}

/* TWI master traffic from the AVR. libsimavr signals each bus event on TWI_IRQ_OUTPUT and expects an
 * addressed slave to answer at once on TWI_IRQ_INPUT: an ACK for the address and written bytes, the
 * data byte for reads. Silence means NACK. */
static void mpu_twi_hook(avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    mpu_t *m = param;
    avr_twi_msg_irq_t v;
    v.u.v = value;
    uint8_t msg = v.u.twi.msg;
    uint8_t addr = v.u.twi.addr;

    if (msg & TWI_COND_STOP) {
        m->selected = 0;
        if (m->has_held) { /* bus idle again: the newest sample reaches the registers */
            mpu_latch(m, m->held);
            m->has_held = 0;
        }
        return;
    }
    if (msg & TWI_COND_START) { /* address byte */
        m->selected = m->present && (addr >> 1) == m->addr;
        if (m->selected) {
            m->expect_ptr = !(addr & 1);
            avr_raise_irq(m->twi_in, avr_twi_irq_msg(TWI_COND_ACK, addr, 1));
        }
        return;
    }
    if (!m->selected)
        return;
    if (msg & TWI_COND_WRITE) {
        if (m->expect_ptr) {
            m->ptr = v.u.twi.data;
            m->expect_ptr = 0;
        } else {
            mpu_write(m, m->ptr++, v.u.twi.data);
        }
        avr_raise_irq(m->twi_in, avr_twi_irq_msg(TWI_COND_ACK, addr, 1));
    } else if (msg & TWI_COND_READ) {
        uint8_t byte = mpu_read(m, m->ptr);
        if (m->ptr != REG_FIFO_R_W) /* burst reads of FIFO_R_W keep draining the FIFO */
            m->ptr++;
        avr_raise_irq(m->twi_in, avr_twi_irq_msg(TWI_COND_READ, addr, byte));
    }
}

/* ---------------------------------------------------------------- UART <-> pseudo-terminal */

#define OUT_CAP (1u << 22) /* 4 MiB: minutes of 200 Hz frames if the host is slow to read */

typedef struct {
    int master;
    uint8_t *out;
    size_t out_head, out_len; /* ring buffer of bytes the AVR sent */
    uint64_t out_total, out_dropped, in_total;
    uint8_t in_buf[256];
    size_t in_len;
    int rx_full;              /* AVR's receive FIFO is full (XOFF) */
    int host_seen;            /* a host has had the slave side open */
    avr_irq_t *uart_in;
} uart_bridge_t;

static void uart_out_hook(avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    uart_bridge_t *u = param;
    u->out_total++;
    if (u->out_len == OUT_CAP) {
        u->out_dropped++;
        return;
    }
    u->out[(u->out_head + u->out_len) % OUT_CAP] = (uint8_t)value;
    u->out_len++;
}

static void uart_xon_hook(avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)value;
    ((uart_bridge_t *)param)->rx_full = 0;
}

static void uart_xoff_hook(avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)value;
    ((uart_bridge_t *)param)->rx_full = 1;
}

/* Move bytes both ways without blocking. Returns 1 if the host side has hung up. */
static int uart_service(uart_bridge_t *u)
{
    while (u->out_len) {
        size_t chunk = u->out_len;
        if (u->out_head + chunk > OUT_CAP)
            chunk = OUT_CAP - u->out_head;
        ssize_t n = write(u->master, u->out + u->out_head, chunk);
        if (n <= 0)
            break; /* EAGAIN: tty queue full, try later; EIO: nobody has the slave open */
        u->out_head = (u->out_head + (size_t)n) % OUT_CAP;
        u->out_len -= (size_t)n;
    }
    struct pollfd p = {u->master, POLLIN, 0};
    int r = poll(&p, 1, 0);
    if (r >= 0 && !(p.revents & POLLHUP))
        u->host_seen = 1;
    if (r > 0) {
        if (p.revents & POLLHUP)
            return u->host_seen; /* HUP before any host opened the port is just "nobody yet" */
        if ((p.revents & POLLIN) && u->in_len < sizeof u->in_buf) {
            ssize_t n = read(u->master, u->in_buf + u->in_len, sizeof u->in_buf - u->in_len);
            if (n > 0)
                u->in_len += (size_t)n;
        }
    }
    /* one byte per service call: the host sends only single command bytes ('H') */
    if (u->in_len && !u->rx_full) {
        avr_raise_irq(u->uart_in, u->in_buf[0]);
        memmove(u->in_buf, u->in_buf + 1, --u->in_len);
        u->in_total++;
    }
    return 0;
}

static int open_pty(char *slave_name, size_t cap)
{
    int master = posix_openpt(O_RDWR | O_NOCTTY);
    if (master < 0 || grantpt(master) || unlockpt(master) || ptsname_r(master, slave_name, cap)) {
        perror("harness: pseudo-terminal");
        exit(2);
    }
    /* Open and close the slave once: from then on the master reports POLLHUP until a host opens it,
     * which is how --wait-open notices the host. */
    int s = open(slave_name, O_RDWR | O_NOCTTY);
    if (s >= 0) {
        struct termios t;
        if (tcgetattr(s, &t) == 0) {
            cfmakeraw(&t);
            tcsetattr(s, TCSANOW, &t);
        }
        close(s);
    }
    fcntl(master, F_SETFL, fcntl(master, F_GETFL) | O_NONBLOCK);
    return master;
}

/* ---------------------------------------------------------------- main */

static volatile sig_atomic_t g_stop;
static void on_signal(int sig)
{
    (void)sig;
    g_stop = 1;
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int16_t *read_samples(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "harness: cannot open sample file %s: %s\n", path, strerror(errno));
        exit(2);
    }
    fseek(f, 0, SEEK_END);
    long size = ftell(f);
    fseek(f, 0, SEEK_SET);
    if (size < 0 || size % 14) {
        fprintf(stderr, "harness: %s: size %ld is not a multiple of 14 bytes (7 x int16 per sample)\n", path,
                size);
        exit(2);
    }
    *n = (size_t)size / 14;
    int16_t *buf = malloc((size_t)size + 14);
    uint8_t *raw = malloc((size_t)size + 14);
    if (!buf || !raw || fread(raw, 1, (size_t)size, f) != (size_t)size) {
        fprintf(stderr, "harness: cannot read %s\n", path);
        exit(2);
    }
    for (size_t i = 0; i < *n * 7; i++) /* file is little-endian whatever the host is */
        buf[i] = (int16_t)(uint16_t)(raw[2 * i] | (raw[2 * i + 1] << 8));
    free(raw);
    fclose(f);
    return buf;
}

static void usage(void)
{
    fprintf(stderr, "usage: harness --firmware F.elf --samples S.bin [--wait-open] [--realtime] "
                    "[--idle-when-done] [--burst-at K] [--brownout-at K] [--whoami 0x68] [--absent] [--stats F.json] [--max-seconds N]\n");
    exit(2);
}

int main(int argc, char **argv)
{
    const char *fw_path = NULL, *samples_path = NULL, *stats_path = NULL;
    int wait_open = 0, realtime = 0, idle_when_done = 0;
    double max_s = 600;
    static mpu_t mpu;
    mpu.addr = 0x68;
    mpu.present = 1;
    mpu.whoami = 0x68;
    mpu.burst_at = (size_t)-1;
    mpu.brownout_at = (size_t)-1;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--firmware") && i + 1 < argc)
            fw_path = argv[++i];
        else if (!strcmp(argv[i], "--samples") && i + 1 < argc)
            samples_path = argv[++i];
        else if (!strcmp(argv[i], "--stats") && i + 1 < argc)
            stats_path = argv[++i];
        else if (!strcmp(argv[i], "--whoami") && i + 1 < argc)
            mpu.whoami = (uint8_t)strtoul(argv[++i], NULL, 0);
        else if (!strcmp(argv[i], "--max-seconds") && i + 1 < argc)
            max_s = atof(argv[++i]);
        else if (!strcmp(argv[i], "--burst-at") && i + 1 < argc)
            mpu.burst_at = (size_t)strtoull(argv[++i], NULL, 0);
        else if (!strcmp(argv[i], "--brownout-at") && i + 1 < argc)
            mpu.brownout_at = (size_t)strtoull(argv[++i], NULL, 0);
        else if (!strcmp(argv[i], "--absent"))
            mpu.present = 0;
        else if (!strcmp(argv[i], "--wait-open"))
            wait_open = 1;
        else if (!strcmp(argv[i], "--realtime"))
            realtime = 1;
        else if (!strcmp(argv[i], "--idle-when-done"))
            idle_when_done = 1;
        else
            usage();
    }
    if (!fw_path || !samples_path)
        usage();
    mpu.samples = read_samples(samples_path, &mpu.n_samples);

    elf_firmware_t fw;
    memset(&fw, 0, sizeof fw);
    if (elf_read_firmware(fw_path, &fw) != 0) {
        fprintf(stderr, "harness: cannot load firmware %s\n", fw_path);
        return 2;
    }
    avr_t *avr = avr_make_mcu_by_name("atmega328p");
    if (!avr) {
        fprintf(stderr, "harness: libsimavr has no atmega328p\n");
        return 2;
    }
    avr_init(avr);
    avr_load_firmware(avr, &fw);
    avr->frequency = F_CPU_HZ;
    avr->log = 1; /* errors only: higher levels trace every TWI byte */

    mpu.avr = avr;
    mpu_reset_regs(&mpu);
    mpu.twi_in = avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_INPUT);
    mpu.int_pin = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('D'), 2);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_OUTPUT), mpu_twi_hook, &mpu);
    avr_raise_irq(mpu.int_pin, 0);

    static uart_bridge_t uart;
    uart.out = malloc(OUT_CAP);
    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
    flags &= ~(uint32_t)AVR_UART_FLAG_STDIO; /* binary frames, not console text */
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    uart.uart_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), uart_out_hook, &uart);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON), uart_xon_hook, &uart);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF), uart_xoff_hook, &uart);

    char slave[128];
    uart.master = open_pty(slave, sizeof slave);
    printf("pty %s\n", slave);
    fflush(stdout);

    signal(SIGTERM, on_signal);
    signal(SIGINT, on_signal);
    double t_start = now_s();
    if (wait_open) { /* hold the board in reset until the host has the port open */
        for (;;) {
            struct pollfd p = {uart.master, POLLIN, 0};
            if (poll(&p, 1, 0) >= 0 && !(p.revents & POLLHUP))
                break;
            if (g_stop || now_s() - t_start > max_s) {
                fprintf(stderr, "harness: nobody opened %s\n", slave);
                return 3;
            }
            usleep(2000);
        }
        usleep(100000);
    }
    double t_run = now_s();
    int state = cpu_Running;
    const char *why = "signal";
    avr_cycle_count_t done_cycle = 0; /* when the last sample was served and the UART had drained */
    int idle = 0;
    while (!g_stop) {
        if (idle) { /* CPU stopped: only keep the pty open until the host leaves */
            if (uart_service(&uart)) {
                why = "host closed the port";
                break;
            }
            if (now_s() - t_start > max_s) {
                why = "max-seconds";
                break;
            }
            usleep(5000);
            continue;
        }
        for (int i = 0; i < 4000 && state != cpu_Done && state != cpu_Crashed; i++)
            state = avr_run(avr);
        if (state == cpu_Done || state == cpu_Crashed) {
            why = state == cpu_Done ? "firmware stopped" : "firmware crashed";
            break;
        }
        if (uart_service(&uart)) {
            why = "host closed the port";
            break;
        }
        double wall = now_s() - t_run;
        if (now_s() - t_start > max_s) {
            why = "max-seconds";
            break;
        }
        if (idle_when_done && mpu.served == mpu.n_samples && !mpu.ticking) {
            if (!done_cycle)
                done_cycle = avr->cycle;
            else if (avr->cycle - done_cycle > F_CPU_HZ / 5 && uart.out_len == 0) {
                idle = 1;
                printf("idle\n"); /* tells a test that every sample was served and sent */
                fflush(stdout);
            }
        }
        if (realtime) { /* never run ahead of the wall clock by more than 2 ms */
            double ahead = (double)avr->cycle / F_CPU_HZ - wall;
            if (ahead > 0.002)
                usleep((useconds_t)((ahead - 0.001) * 1e6));
        }
    }
    uart_service(&uart);
    double wall = now_s() - t_run;
    double sim_s = (double)avr->cycle / F_CPU_HZ;
    fprintf(stderr, "harness: %s; served %zu/%zu samples, %.3f s simulated in %.3f s wall (x%.2f), UART %llu bytes out\n",
            why, mpu.served, mpu.n_samples, sim_s, wall, wall > 0 ? sim_s / wall : 0.0,
            (unsigned long long)uart.out_total);
    if (stats_path) {
        FILE *f = fopen(stats_path, "w");
        if (f) {
            fprintf(f,
                    "{\"served\": %zu, \"n_samples\": %zu, \"period_cycles\": %llu, \"first_drdy_cycle\": %llu, "
                    "\"f_cpu_hz\": %u, \"sim_seconds\": %.6f, \"wall_seconds\": %.6f, \"uart_bytes_out\": %llu, "
                    "\"uart_bytes_dropped\": %llu, \"uart_bytes_in\": %llu, \"mpu_reg_writes\": %u, \"fifo_overflows\": %u, \"exit\": \"%s\"}\n",
                    mpu.served, mpu.n_samples, (unsigned long long)mpu.period_cycles,
                    (unsigned long long)mpu.first_drdy_cycle, F_CPU_HZ, sim_s, wall,
                    (unsigned long long)uart.out_total, (unsigned long long)uart.out_dropped,
                    (unsigned long long)uart.in_total, mpu.reg_writes, mpu.fifo_overflows, why);
            fclose(f);
        }
    }
    return state == cpu_Crashed ? 4 : 0;
}
