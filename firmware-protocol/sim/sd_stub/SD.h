/* Stand-in for the Arduino SD library's API (the subset sd_sink.cpp uses), for building the
 * BOOTNAV_SD_LOG=1 firmware where Debian has no SD library: `make BUILD=build/sdstub SD_LIB=sim/sd_stub`.
 * It models a Nano whose card slot is empty: begin() fails, so the firmware must report
 * "SD absent, card did not initialise" and keep streaming. Not for real hardware. */
#ifndef BOOTNAV_SD_STUB_H
#define BOOTNAV_SD_STUB_H

#include <Arduino.h>

#define FILE_READ 0x01
#define FILE_WRITE 0x17

class File : public Print {
public:
    File() : open_(false) {}
    size_t write(uint8_t) override { return 0; }
    size_t write(const uint8_t *, size_t) override { return 0; }
    void flush() {}
    operator bool() const { return open_; }

private:
    bool open_;
};

class SDClass {
public:
    bool begin(uint8_t cs_pin);
    bool exists(const char *path);
    File open(const char *path, uint8_t mode = FILE_READ);
};

extern SDClass SD;

#endif
