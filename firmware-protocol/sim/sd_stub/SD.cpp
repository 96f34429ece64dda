/* Empty card slot; see SD.h. */
#include "SD.h"

SDClass SD;

bool SDClass::begin(uint8_t cs_pin)
{
    pinMode(cs_pin, OUTPUT); /* as the real library does: CS high = card deselected */
    digitalWrite(cs_pin, HIGH);
    return false;
}

bool SDClass::exists(const char *) { return false; }

File SDClass::open(const char *, uint8_t) { return File(); }
