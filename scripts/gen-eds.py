#!/usr/bin/env python3
"""Generates the CiA 306 EDS files in config/devices/ from the object tables
of the three device manuals (manuals J, E and F, cited by their own sections).

Identity facts (vendor IDs, product codes, family names, quirk constants) are
not repeated here: they are read from the family modules in
daemon/families/, the one place they are defined.

    scripts/gen-eds.py [OUTPUT_DIR]      (default: config/devices next to tools/)

The output is deterministic (no timestamps), so running the script again must
leave `git diff config/devices` empty. Edit the tables here, never the .eds.
"""
import argparse
import os
import re
import sys

BOOL, I8, I16, I32, U8, U16, U32, VS, DOMAIN = 0x1, 0x2, 0x3, 0x4, 0x5, 0x6, 0x7, 0x9, 0xF
CREATION_DATE = "11-22-2025"  # fixed, for reproducible output
FAMILIES_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "daemon", "families")


def family_source(file_name):
    with open(os.path.join(FAMILIES_DIR, file_name)) as f:
        return f.read()


def family_fact(header, constant):
    """The value of `inline constexpr ... constant = <number>;` in a family header."""
    m = re.search(r"\b%s\s*=\s*(0x[0-9A-Fa-f]+|\d+)\s*;" % re.escape(constant), family_source(header))
    if not m:
        sys.exit("gen-eds.py: %s is not defined in daemon/families/%s" % (constant, header))
    return int(m.group(1), 0)


def family_name(module):
    """The EDS [Cobridge] Family value: `.name = "..."` in daemon/families/<module>.cpp."""
    m = re.search(r'\.name = "([^"]+)"', family_source(module + ".cpp"))
    if not m:
        sys.exit("gen-eds.py: no family name in daemon/families/%s.cpp" % module)
    return m.group(1)


NOVOTECHNIK = family_fact("novotechnik.hpp", "kNovotechnikVendor")
SAVE_SIGNATURE = family_fact("family.hpp", "kSaveSignature")


class Sub:
    def __init__(self, sub, name, dtype, access, default=None, pdo=0, low=None, high=None):
        self.sub, self.name, self.dtype, self.access = sub, name, dtype, access
        self.default, self.pdo, self.low, self.high = default, pdo, low, high


class Obj:
    def __init__(self, index, name, kind="VAR", dtype=None, access=None, default=None, pdo=0,
                 low=None, high=None, subs=None):
        self.index, self.name, self.kind = index, name, kind
        self.var = Sub(0, name, dtype, access, default, pdo, low, high) if kind == "VAR" else None
        self.subs = subs or []


def var(index, name, dtype, access, default=None, pdo=0, low=None, high=None):
    return Obj(index, name, "VAR", dtype, access, default, pdo, low, high)


def rec(index, name, subs, kind="RECORD"):
    return Obj(index, name, kind, subs=subs)


def count(n, name="Highest sub-index supported", access="ro"):
    return Sub(0, name, U8, access, n)


def channels(index, name, n, entry_name, dtype, access, default, pdo=0, sub0_name="Number of available channels"):
    subs = [count(n, sub0_name)]
    for ch in range(1, n + 1):
        subs.append(Sub(ch, entry_name.format(ch=ch), dtype, access, default, pdo))
    return rec(index, name, subs, "ARRAY")


HEX_DIGITS = {BOOL: 0, I8: 2, U8: 2, I16: 4, U16: 4, I32: 8, U32: 8}


def fmt_value(v, dtype):
    """Numbers as the manuals print them: hex padded to the type's width."""
    if v is None:
        return ""
    if isinstance(v, str):
        return v
    digits = HEX_DIGITS.get(dtype, 0)
    if v < 0 or digits == 0:
        return str(v)
    return "0x%0*X" % (digits, v)


def write_entry(out, section, s, object_type):
    out.append("[%s]" % section)
    out.append("ParameterName=%s" % s.name)
    out.append("ObjectType=0x%X" % object_type)
    out.append("DataType=0x%04X" % s.dtype)
    out.append("AccessType=%s" % s.access)
    out.append("DefaultValue=%s" % fmt_value(s.default, s.dtype))
    if s.low is not None:
        out.append("LowLimit=%s" % fmt_value(s.low, s.dtype))
    if s.high is not None:
        out.append("HighLimit=%s" % fmt_value(s.high, s.dtype))
    out.append("PDOMapping=%d" % s.pdo)
    out.append("")


def render(header, file_name, description, device_info, cobridge, objects):
    out = [";" + (" " + line if line else "") for line in header] + [""]
    out += ["[FileInfo]", "FileName=%s" % file_name, "FileVersion=1", "FileRevision=0", "EDSVersion=4.0",
            "Description=%s" % description, "CreationTime=12:00PM", "CreationDate=%s" % CREATION_DATE,
            "CreatedBy=cobridge scripts/gen-eds.py", ""]
    out.append("[DeviceInfo]")
    out += ["%s=%s" % kv for kv in device_info]
    out.append("")
    if cobridge:
        out.append("[Cobridge]")
        out += ["%s=%s" % kv for kv in cobridge]
        out.append("")
    objects = sorted(objects, key=lambda o: o.index)
    indices = [o.index for o in objects]
    assert len(set(indices)) == len(indices), "duplicate object"
    mandatory = [i for i in indices if i in (0x1000, 0x1001, 0x1018)]
    manufacturer = [i for i in indices if 0x2000 <= i <= 0x5FFF]
    optional = [i for i in indices if i not in mandatory and i not in manufacturer]
    for name, lst in (("MandatoryObjects", mandatory), ("OptionalObjects", optional),
                      ("ManufacturerObjects", manufacturer)):
        out.append("[%s]" % name)
        out.append("SupportedObjects=%d" % len(lst))
        out += ["%d=0x%04X" % (n + 1, i) for n, i in enumerate(lst)]
        out.append("")
    for o in objects:
        if o.kind == "VAR":
            write_entry(out, "%04X" % o.index, o.var, 0x7)
            continue
        out += ["[%04X]" % o.index, "ParameterName=%s" % o.name,
                "ObjectType=0x%X" % (0x8 if o.kind == "ARRAY" else 0x9),
                "SubNumber=%d" % len(o.subs), ""]
        for s in o.subs:
            write_entry(out, "%04Xsub%X" % (o.index, s.sub), s, 0x7)
    return "\n".join(out)  # LF for clean diffs; the parser also takes CRLF


def novotechnik_comm(product, sub0_1010, legacy, pdo_map2):
    """Communication profile area shared by J§1.3.1 and E§4.1."""
    store = [count(sub0_1010),
             Sub(1, "Save all parameters", U32, "rw", 0),
             Sub(2, "Save communication parameters", U32, "rw", 0),
             Sub(3, "Save application parameters", U32, "rw", 0),
             Sub(4, "Save manufacturer defined parameters" if legacy else "Save user data parameters", U32, "rw", 0)]
    if sub0_1010 >= 5:
        store.append(Sub(5, "Save manufacturer defined parameters (do not use)", U32, "rw", 0))
    restore = [count(4),
               Sub(1, "Restore all default parameters", U32, "rw", 0),
               Sub(2, "Restore communication default parameters", U32, "rw", 0),
               Sub(3, "Restore application default parameters", U32, "rw", 0),
               Sub(4, "Restore manufacturer defined parameters" if legacy else "Restore user data parameters",
                   U32, "rw", 0)]
    mapping = lambda idx, name: rec(idx, name, [
        Sub(0, "Number of mapped objects", U8, "rw", 2),
        Sub(1, "Mapping entry 1", U32, "rw", 0x60200120),
        Sub(2, "Mapping entry 2", U32, "rw", pdo_map2),
        Sub(3, "Mapping entry 3", U32, "rw", 0),
        Sub(4, "Mapping entry 4", U32, "rw", 0),
        Sub(5, "Mapping entry 5", U32, "rw", 0)])
    return [
        var(0x1005, "COB-ID SYNC", U32, "rw", 0x80),
        var(0x1008, "Manufacturer device name", VS, "const"),
        var(0x1009, "Manufacturer hardware version", VS, "const"),
        var(0x100A, "Manufacturer software version", VS, "const"),
        var(0x100C, "Guard time", U16, "rw", 0),
        var(0x100D, "Life time factor", U8, "rw", 0),
        rec(0x1010, "Store parameter field", store, "ARRAY"),
        rec(0x1011, "Restore default parameters", restore, "ARRAY"),
        var(0x1014, "COB-ID EMCY", U32, "ro", "$NODEID+0x80"),
        var(0x1017, "Producer heartbeat time", U16, "rw", 0),
        rec(0x1018, "Identity object", [
            count(4, "Number of entries"),
            Sub(1, "Vendor-ID", U32, "ro", NOVOTECHNIK),
            Sub(2, "Product code", U32, "ro", product),
            Sub(3, "Revision number", U32, "ro"),
            Sub(4, "Serial number", U32, "ro")]),
        rec(0x1800, "TPDO1 communication parameter", [
            count(5),
            Sub(1, "COB-ID used by TPDO", U32, "rw", "$NODEID+0x40000180"),
            Sub(2, "Transmission type", U8, "rw", 0xFE),
            Sub(3, "Inhibit time", U16, "rw", 0),
            Sub(4, "Compatibility entry", U8, "rw", 0),
            Sub(5, "Event timer", U16, "rw", 0)]),
        rec(0x1801, "TPDO2 communication parameter", [
            count(3),
            Sub(1, "COB-ID used by TPDO", U32, "rw", "$NODEID+0x40000280"),
            Sub(2, "Transmission type", U8, "rw", 0x01),
            Sub(3, "Inhibit time", U16, "rw", 0)]),
        mapping(0x1A00, "TPDO1 mapping parameter"),
        mapping(0x1A01, "TPDO2 mapping parameter"),
        var(0x1F80, "NMT startup", U32, "rw", 0),
    ]


def device_info(vendor_name, vendor, product_name, product, bauds, order_code=""):
    info = [("VendorName", vendor_name), ("VendorNumber", "0x%08X" % vendor),
            ("ProductName", product_name), ("ProductNumber", "0x%08X" % product),
            # 0 = this file covers every revision (DeviceCatalog picks the
            # highest RevisionNumber <= the device's).
            ("RevisionNumber", "0x00000000"), ("OrderCode", order_code)]
    for rate in (10, 20, 50, 125, 250, 500, 800, 1000):
        info.append(("BaudRate_%d" % rate, "1" if rate in bauds else "0"))
    info += [("SimpleBootUpMaster", "0"), ("SimpleBootUpSlave", "1"), ("Granularity", "8"),
             ("DynamicChannelsSupported", "0"), ("GroupMessaging", "0"), ("NrOfRXPDO", "0"),
             ("NrOfTXPDO", "2"), ("LSS_Supported", "1")]
    return info


# ---------------------------------------------------------------------------
# J: Novotechnik rotary sensors (seed 000, J§1.3.1-1.3.3)

ROTARY_SERIES = [  # (series, product code per J§1.2.1, legacy firmware per J§1.12 V10)
    ("RFC-4800", family_fact("novotechnik_rotary.hpp", "kRfc4800Product"), False),
    ("RSA-3200", family_fact("novotechnik_rotary.hpp", "kRsa3200Product"), False),
    ("RFE-3200", family_fact("novotechnik_rotary.hpp", "kRfe3200Product"), False),
    ("RSX-7900", family_fact("novotechnik_rotary.hpp", "kRsx7900Product"), True),
    ("RFX-6900", family_fact("novotechnik_rotary.hpp", "kRfx6900Product"), True),
]

ROTARY_HEADER = """\
Novotechnik {series} rotary sensor, {ch}-channel variant, CANopen (CiA 301 V4.2, CiA 406 V3.2, CiA 305).
Source: "User Manual CANopen for Rotary Sensors" (Japanese edition, V11 07.12.20), manual J:
  J§1.2.1 identity, J§1.2.2 bit rates, J§1.3.1 communication area, J§1.3.2 device profile area,
  J§1.3.3 manufacturer area. Generated by scripts/gen-eds.py: do not edit.
Product code 0x{product:04X} ({series}); vendor 0x{vendor:08X}. The 1- and 2-channel variants share the product
code; [Cobridge] Variant/VariantProbe (0x6020sub0 = number of channels) tells them apart.
Errata decisions (J as printed -> this file):
- 0x1010/0x1011/0x1018/0x1800/0x1801 sub 0 rows are missing in J§1.3.1: 1010/0 = {s1010},
  1011/0 = 4, 1018/0 = 4, 1800/0 = 5, 1801/0 = 3.{legacy_note}
- 0x1018/2 printed "0x0 (see 1.2.1)": the series product code from J§1.2.1.
- 0x1018/3 and /4 (revision, serial) are per device: no DefaultValue.
- 0x6323 printed sub 0 INTEGER8, sub 1/2 UNSIGNED32: UNSIGNED8 / INTEGER32 like 0x6320-0x6322.
- 0x6331/2 misprinted "6330/2": written as 0x6331sub2.
- 0x6300/1-2 CAM state printed rw: kept rw as printed (CiA 406 and manual E say ro).
- 0x6400/1-2 default printed 0x00000000 for UNSIGNED8, 0x100C/0x100D printed 0x00000000: 0.
- 0x6501 printed "measuring units per resolution": named "per revolution".
- 0x6001/0x6002 HighLimit 0x4000: J§1.4.2 says the default is the maximum (resolution can only be reduced).
- 0x1008-0x100A, 0x2001, 0x6507 defaults are "e.g." / "by ordering code" values: no DefaultValue.
- 0x2003 "ordering" and 0x2004 "custom" (J§1.3.3) have no type, access or sub-indices in J and are not
  writable by users: left out.
- 0x1017 kept although J§1.2.2 says "heartbeat: no".
- 0x1A00/0x1A01 sub 2 default: 0x60300110 (speed ch1) on 1-channel, 0x60200220 (position ch2) on 2-channel."""


def rotary_objects(product, legacy, ch):
    s1010 = 4 if legacy else 5
    objs = [
        var(0x1000, "Device type", U32, "const", 0x00010196),
        var(0x1001, "Error register", U8, "ro", 0),
        var(0x1002, "Manufacturer status register", U32, "ro", 0),
    ]
    objs += novotechnik_comm(product, s1010, legacy, 0x60300110 if ch == 1 else 0x60200220)
    objs += [
        var(0x2000, "Node-ID", U8, "rw", 0x7F, low=1, high=127),
        var(0x2001, "CAN bit rate", U16, "rw"),
        var(0x6000, "Operating parameters", U16, "rw", 0),
        var(0x6001, "Measuring units per revolution", U32, "rw", 0x00004000, high=0x00004000),
        var(0x6002, "Total measuring range in measuring units", U32, "rw", 0x00004000, high=0x00004000),
        channels(0x6010, "Preset value", ch, "Preset value channel {ch}", I32, "rw", 0),
        channels(0x6020, "Position value", ch, "Position value channel {ch}", I32, "ro", 0, pdo=1),
        channels(0x6030, "Speed value", ch, "Speed value channel {ch}", I16, "ro", 0, pdo=1),
        channels(0x6300, "CAM state register", ch, "CAM state channel {ch}", U8, "rw", 0, pdo=1),
        channels(0x6301, "CAM enable register", ch, "CAM enable channel {ch}", U8, "rw", 0),
        channels(0x6302, "CAM polarity register", ch, "CAM polarity channel {ch}", U8, "rw", 0),
    ]
    for cam in range(4):
        objs.append(channels(0x6310 + cam, "CAM%d low limit" % (cam + 1), ch,
                             "CAM%d low limit channel {ch}" % (cam + 1), I32, "rw", 0))
        objs.append(channels(0x6320 + cam, "CAM%d high limit" % (cam + 1), ch,
                             "CAM%d high limit channel {ch}" % (cam + 1), I32, "rw", 0x00003FFF))
        objs.append(channels(0x6330 + cam, "CAM%d hysteresis" % (cam + 1), ch,
                             "CAM%d hysteresis channel {ch}" % (cam + 1), I16, "rw", 0))
    objs += [
        channels(0x6400, "Area state register", ch, "Work area state channel {ch}", U8, "ro", 0, pdo=1,
                 sub0_name="Number of available work areas"),
        channels(0x6401, "Work area low limit", ch, "Work area low limit {ch}", I32, "rw", 0),
        channels(0x6402, "Work area high limit", ch, "Work area high limit {ch}", I32, "rw", 0x00003FFF),
        var(0x6500, "Operating status", U16, "ro", 0),
        var(0x6501, "Measuring units per revolution (physical)", U32, "ro", 0x00004000),
        var(0x6502, "Number of distinguishable revolutions", U16, "ro", 0x0001),
        var(0x6503, "Alarms", U16, "ro", 0, pdo=1),
        var(0x6504, "Supported alarms", U16, "ro", 0x1001),
        var(0x6505, "Warnings", U16, "ro", 0, pdo=1),
        var(0x6506, "Supported warnings", U16, "ro", 0x1000),
        var(0x6507, "Profile and software version", I32, "ro"),
    ]
    return objs


def rotary_files():
    for series, product, legacy in ROTARY_SERIES:
        for ch in (1, 2):
            name = "novotechnik-%s-%dch.eds" % (series.lower().replace("-", ""), ch)
            legacy_note = ("\n  RSX-7900/RFX-6900 firmware (J§1.12 V10) has no 0x1010/5; 0x1010/4 and 0x1011/4 are"
                           "\n  the manufacturer-defined parameters." if legacy else
                           "\n  0x1010/5 exists but must never receive 'save' (J§1.10).")
            header = ROTARY_HEADER.format(series=series, ch=ch, product=product, vendor=NOVOTECHNIK,
                                          s1010=4 if legacy else 5,
                                          legacy_note=legacy_note).split("\n")
            info = device_info("Novotechnik Messwertaufnehmer OHG", NOVOTECHNIK,
                               "%s rotary sensor %d-channel" % (series, ch), product,
                               (50, 125, 250, 500, 800, 1000))
            cobridge = [("Family", family_name("novotechnik_rotary")), ("Variant", "%dch" % ch),
                        ("VariantProbe", "0x6020sub0"), ("VariantValue", str(ch))]
            yield name, render(header, name, "%s rotary sensor, %d channel%s" % (series, ch, "s" if ch == 2 else ""), info, cobridge,
                               rotary_objects(product, legacy, ch))


# ---------------------------------------------------------------------------
# F: ifm RM8xxx / RM9xxx (seed 001, F§7.3-7.5)

IFM = family_fact("ifm_rm.hpp", "kIfmVendor")
IFM_PRODUCT = family_fact("ifm_rm.hpp", "kIfmPrintedProduct")
IFM_SAVE_WITH_RESET = family_fact("ifm_rm.hpp", "kIfmSaveWithResetObject")
IFM_SAVE_WITH_RESET_CODE = family_fact("ifm_rm.hpp", "kIfmSaveWithResetCode")

IFM_HEADER = """\
ifm electronic RM8xxx / RM9xxx magnetic absolute encoder, CANopen (DS301 V4.02, CiA 406, DS305).
Source: ifm "Manuel d'utilisation - Codeur absolu magnetique avec interface CANopen", 704820/02 04/2017
(French), manual F: F§5.3 addressing, F§7.3 communication objects, F§7.4 manufacturer objects,
F§7.5 device objects. Generated by scripts/gen-eds.py: do not edit.
Vendor 0x{vendor:08X} ("ifm"). Product code: F§7.3 prints 0x1018/2 as "0x43 0x41". F writes "save"
high byte first (65h 76h 61h 73h = 0x{save:08X}), so the same reading gives 0x{product:08X}. Because this is
uncertain, [Cobridge] MatchAnyProduct=1 makes DeviceCatalog use this file for any ifm product code
that no other file claims.
Errata decisions (F as printed -> this file):
- 0x1000 "N/A": no DefaultValue (CiA 406 would be 0x00010196 or 0x00020196; not documented).
- 0x1018/0 printed 1 with four entries: 4. 0x1018/4 "see label": no DefaultValue.
- 0x1003/0 printed ro, but F says errors are cleared by writing 0 to it: rw.
- 0x1800/3, /5 and 0x1801/3, /5 typed u32 (CiA 301: UNSIGNED16): kept u32 as printed.
  Sub 4 is "non disponible": left out, so SubNumber=5 with sub 0 = 5 (highest sub-index).
- 0x1800/5 default "0x64 or 0": 0x64, the same 100 ms as 0x6200.
- 0x1801/3 misnamed "Mode de transmission": named "Inhibit time".
- 0x1A00/0, 0x1A01/0 ro with value 2 but only sub 1 listed: sub 1 and sub 2 without default.
- 0x1F50/0 printed 2h but only sub 1 is listed: 1 (sub 0 is the highest sub-index, CiA 301 §7.4.3).
- 0x1F51/0 has no value in F: 1.
- 0x2101 listed twice, u16 (<= 12 bit) and u32 (> 12 bit): UNSIGNED32.
- 0x2160 header u8 4h vs sub 0 u32 rw 0x0: sub 0 UNSIGNED8 ro 4.
- 0x3000 node number default "-": F§5.3.1 says the address is 32 by default and F§7.4 says node-ID =
  value + 1, so DefaultValue 0x1F (31); limits 0..126 (node-ID 1..127).
- 0x3001 limits 0..7 (eight bit rates, F§7.4: 0=20 ... 3=125 ... 7=1000 kbit/s). CiA 306 has no
  BaudRate_100, so 100 kbit/s (value 2) is not in [DeviceInfo].
- 0x3011 speed typed u8: kept UNSIGNED8 as printed.
- 0x6000 default 1h while its twin 0x2100 defaults to 0h: both kept as printed.
- 0x6001/0x6002 "see label", 0x1008 default "RM9000" kept, 0x1009/0x100A "x.x": no DefaultValue.
- 0x6200 range "1..65538 ms": limits 1..65535.
- 0x6300/1 default 4h as printed; 0x6301/1 has no default.
- 0x6310/0, 0x6311/0 typed u32; 0x6401/0, 0x6402/0, 0x650A/0 typed integer32: UNSIGNED8.
- 0x6400 sub names copied from 0x6001/0x6002: named after their function."""


def ifm_objects():
    tpdo = lambda idx, n, cob, ttype, event: rec(idx, "TPDO%d communication parameter" % n, [
        count(5, "Number of sub-indices"),
        Sub(1, "COB-ID", U32, "rw", cob),
        Sub(2, "Transmission type", U8, "rw", ttype),
        Sub(3, "Inhibit time", U32, "rw", 0),
        Sub(5, "Event timer", U32, "rw", event)])
    mapping = lambda idx, n: rec(idx, "TPDO%d mapping parameter" % n, [
        count(2, "Number of sub-indices"),
        Sub(1, "1st mapped object", U32, "rw"),
        Sub(2, "2nd mapped object", U32, "rw")])
    objs = [
        var(0x1000, "Device type", U32, "ro"),
        var(0x1001, "Error register", U8, "ro"),
        rec(0x1003, "Pre-defined error field",
            [count(0, "Number of errors", "rw")] +
            [Sub(n, "Error history %d" % n, U32, "ro") for n in range(1, 11)], "ARRAY"),
        var(0x1005, "COB-ID SYNC", U32, "rw", 0x80),
        var(0x1006, "Communication cycle period", U32, "rw", 0),
        var(0x1007, "Synchronous window length", U32, "rw", 0),
        var(0x1008, "Manufacturer device name", VS, "ro", "RM9000"),
        var(0x1009, "Manufacturer hardware version", VS, "ro"),
        var(0x100A, "Manufacturer software version", VS, "ro"),
        var(0x100C, "Guard time", U16, "rw", 0),
        var(0x100D, "Life time factor", U8, "rw", 0),
        rec(0x1010, "Store parameters", [count(1, "Number of sub-indices"),
                                         Sub(1, "Store all parameters", U32, "rw")], "ARRAY"),
        rec(0x1011, "Restore parameters", [count(1, "Number of sub-indices"),
                                           Sub(1, "Restore all parameters", U32, "rw")], "ARRAY"),
        var(0x1012, "COB-ID time stamp object", U32, "rw", 0x100),
        var(0x1013, "High resolution time stamp", U32, "rw", 0),
        var(0x1014, "COB-ID emergency object", U32, "rw", "$NODEID+0x80"),
        rec(0x1016, "Consumer heartbeat time", [count(1, "Number of sub-indices"),
                                                Sub(1, "Consumer heartbeat time", U32, "rw", 0)], "ARRAY"),
        var(0x1017, "Producer heartbeat time", U16, "rw", 0),
        rec(0x1018, "Identity object", [
            count(4, "Number of entries"),
            Sub(1, "Vendor-ID", U32, "ro", IFM),
            Sub(2, "Product code", U32, "ro", IFM_PRODUCT),
            Sub(3, "Revision number", U32, "ro", 0x00010000),
            Sub(4, "Serial number", U32, "ro")]),
        rec(0x1020, "Verify configuration", [count(2, "Number of entries"),
                                             Sub(1, "Configuration date", U32, "rw"),
                                             Sub(2, "Configuration time", U32, "rw")]),
        rec(0x1029, "Error behaviour", [count(1, "Number of entries"),
                                        Sub(1, "Communication error", U8, "rw", 0)], "ARRAY"),
        tpdo(0x1800, 1, "$NODEID+0x180", 0xFE, 0x64),
        tpdo(0x1801, 2, "$NODEID+0x280", 0x01, 0x01),
        mapping(0x1A00, 1),
        mapping(0x1A01, 2),
        rec(0x1F50, "Download program area", [count(1, "Number of sub-indices"),
                                              Sub(1, "Program data", DOMAIN, "wo")], "ARRAY"),
        rec(0x1F51, "Program control", [count(1, "Number of entries"),
                                        Sub(1, "Program control", U32, "rw")], "ARRAY"),
        # F§7.4
        var(0x2000, "Position value (manufacturer)", U32, "ro"),
        var(0x2100, "Operating parameters (manufacturer)", U16, "rw", 0),
        var(0x2101, "Resolution per revolution", U32, "rw"),
        var(0x2102, "Total resolution", U32, "rw", 0x01000000),
        var(0x2103, "Preset value (manufacturer)", U32, "rw", 0),
        var(0x2104, "Limit switch min", U32, "rw", 0),
        var(0x2105, "Limit switch max", U32, "rw", 0),
        rec(0x2160, "Customer storage", [count(4, "Number of sub-indices")] +
            [Sub(n, "Customer storage %d" % n, U32, "rw", 0) for n in range(1, 5)], "ARRAY"),
        var(0x2200, "Cyclic timer PDO", U16, "ro", 0),
        var(IFM_SAVE_WITH_RESET, "Save parameter with reset", U32, "wo", IFM_SAVE_WITH_RESET_CODE),
        var(0x3000, "Node number", U8, "rw", 0x1F, low=0, high=126),
        var(0x3001, "Baud rate", U8, "rw", 0x03, low=0, high=7),
        rec(0x3010, "Speed control", [count(2, "Number of sub-indices"),
                                      Sub(1, "Enable speed", U8, "rw", 0),
                                      Sub(2, "Speed mode", U8, "rw", 0, low=0, high=2)]),
        var(0x3011, "Speed value", U8, "ro", pdo=1),
        var(0x4000, "Bootloader control", U32, "wo"),
        # F§7.5
        var(0x6000, "Operating parameters", U16, "rw", 0x0001),
        var(0x6001, "Measuring units per revolution", U32, "rw"),
        var(0x6002, "Total measuring range in measuring units", U32, "rw"),
        var(0x6003, "Preset value", U32, "rw", 0),
        var(0x6004, "Position value", U32, "ro", pdo=1),
        channels(0x6030, "Speed value", 1, "Speed value channel {ch}", I16, "ro", None, pdo=1,
                 sub0_name="Number of sub-indices"),
        var(0x6200, "Event time", U16, "rw", 0x64, low=1, high=0xFFFF),
        channels(0x6300, "Cam state register", 1, "Cam state channel {ch}", U8, "ro", 0x04, pdo=1,
                 sub0_name="Number of sub-indices"),
        channels(0x6301, "Cam enable register", 1, "Cam enable channel {ch}", U8, "rw", None,
                 sub0_name="Number of sub-indices"),
        channels(0x6302, "Cam polarity register", 1, "Cam polarity channel {ch}", U8, "rw", 0,
                 sub0_name="Number of sub-indices"),
    ]
    for cam in range(8):
        for base, what in ((0x6310, "low limit"), (0x6320, "high limit"), (0x6330, "hysteresis")):
            objs.append(channels(base + cam, "Cam%d %s" % (cam + 1, what), 1,
                                 "Cam%d %s channel{ch}" % (cam + 1, what), U32, "rw", 0,
                                 sub0_name="Highest sub-index supported"))
    objs += [
        channels(0x6400, "Area state register", 1, "Area state channel {ch}", U8, "ro", None, pdo=1,
                 sub0_name="Number of sub-indices"),
        channels(0x6401, "Work area low limit", 1, "Work area low limit channel {ch}", I32, "rw", 0,
                 sub0_name="Number of sub-indices"),
        channels(0x6402, "Work area high limit", 1, "Work area high limit channel {ch}", I32, "rw", 0,
                 sub0_name="Number of sub-indices"),
        var(0x6500, "Operating status", U16, "ro"),
        var(0x6501, "Single-turn resolution", U32, "ro"),
        var(0x6502, "Number of distinguishable revolutions", U16, "ro"),
        var(0x6504, "Supported alarms", U16, "ro"),
        var(0x6507, "Profile and software version", U32, "ro"),
        var(0x6509, "Offset value", I32, "ro", 0),
        rec(0x650A, "Module identification", [
            count(3, "Highest sub-index supported"),
            Sub(1, "Manufacturer offset value", I32, "ro"),
            Sub(2, "Manufacturer min position value", I32, "ro"),
            Sub(3, "Manufacturer max position value", I32, "ro")]),
        var(0x650B, "Serial number", U32, "ro"),
    ]
    return objs


def ifm_file():
    name = "ifm-rm8-rm9.eds"
    info = device_info("ifm electronic gmbh", IFM, "RM8xxx/RM9xxx magnetic absolute encoder", IFM_PRODUCT,
                       (20, 50, 125, 250, 500, 800, 1000))
    cobridge = [("Family", family_name("ifm_rm")), ("MatchAnyProduct", "1")]
    header = IFM_HEADER.format(vendor=IFM, save=SAVE_SIGNATURE, product=IFM_PRODUCT)
    return name, render(header.split("\n"), name, "ifm RM8xxx/RM9xxx absolute encoder", info, cobridge,
                        ifm_objects())


# ---------------------------------------------------------------------------
# E: Novotechnik multiturn MZ1-2200 / MC1-2800 / MB1-3600 (seed 003, E§4.1-4.3)

MULTITURN_PRODUCT = family_fact("novotechnik_multiturn.hpp", "kMultiturnProduct")
MULTITURN_PRE_V03_PRODUCTS = [family_fact("novotechnik_multiturn.hpp", c)
                              for c in ("kMz12200V02Product", "kMc12800V02Product", "kMb13600V02Product")]

MULTITURN_HEADER = """\
Novotechnik multiturn series MZ1-2200 / MC1-2800 / MB1-3600 with condition monitoring, CANopen
(CiA 301 V4.2, CiA 406 V3.2, CiA 305 V3.0.0).
Source: Novotechnik "CANopen" manual for the multiturn series (English, V03 30.09.25), manual E:
  E§3.1 basics, E§4.1 communication area, E§4.2 device profile area, E§4.3 manufacturer area
  (condition monitoring), E§13 revision history. Generated by
  scripts/gen-eds.py: do not edit.
Identity: vendor 0x{vendor:08X}; product 0x{product:04X} "Multiturn series" since V03; devices documented before V03
report 0x{mz:04X} (MZ1-2200), 0x{mc:04X} (MC1-2800) or 0x{mb:04X} (MB1-3600) (E§13 V03), listed in
[Cobridge] AdditionalProductNumbers so DeviceCatalog selects this file for all four.
Errata decisions (E as printed -> this file):
- 0x1001 printed Unsigned16: UNSIGNED8 as CiA 301, manual J and F.
- 0x1002 printed Unsigned16 with bits 0..31 defined in E§10.1: UNSIGNED32.
- 0x1010/0x1011/0x1018/0x1800/0x1801 sub 0 rows missing: 1010/0 = 5, 1011/0 = 4, 1018/0 = 4, 1800/0 = 5,
  1801/0 = 3 (as for manual J). 0x1010/5 must never receive 'save' (E§11).
- 0x1018/1 printed "0x0000182": 0x00000182. 0x1018/3, /4 are per device: no DefaultValue.
- 0x1029/0 printed RW: ro (a fixed record's highest sub-index).
- 0x1A00/1, 0x1A01/1 default 0x60200120 maps 0x6020, which E does not define: kept as printed,
  and 0x6020 is defined here (ARRAY, sub 1 INTEGER32 ro, PDO-mappable) as the alias of the position
  0x6004 the device answers it as, so that a master importing this file decodes the default TPDOs
  (CiA 301 §7.4.8.1: a mapping entry names an object of the dictionary).
- 0x6000 printed Unsigned8 with default 0x0000: kept UNSIGNED8 as printed; note that J and F use
  UNSIGNED16 and E§5.3 inverts the scaling bit.
- 0x6313/1 row named "CAM 1 high limit" and the 0x6320 row has no name: named by function.
- 0x6504 = 0xC002 and 0x6506 = 0xC05C kept as printed although E§10.2/10.3 imply 0x3003/0x305C.
- 0x2100, 0x2101, 0x2300/1..6 typed "Bool", access "W", default 0x01: BOOLEAN wo default 1.
- 0x230A default "0x0000FFFF = 65535h" (hours): 0x0000FFFF.
- 0x232A default "6 [min]": 6.
- 0x6031/2 allows 1, 2, 3, 6, 12, 25 ms; the E§5.2 table also lists 0: limits 0..25.
- Limits from E§4.3 / E§5: 0x2000 1..127, 0x2010/1 0..7, 0x2010/2 0..8, 0x2104 0..3, 0x233A 0..4,
  0x1029/1-2 0..2.
- "e.g.", "-", "per data sheet" and "by ordering code" defaults (0x1008-0x100A, 0x2001-0x2003, counters,
  thresholds, 0x6507, 0x6508, 0x650B, 0x234A): no DefaultValue."""


def multiturn_objects():
    objs = [
        var(0x1000, "Device type", U32, "const", 0x00020196),
        var(0x1001, "Error register", U8, "ro", 0),
        var(0x1002, "Manufacturer status register", U32, "ro", 0),
    ]
    objs += novotechnik_comm(MULTITURN_PRODUCT, 5, False, 0x60300110)
    objs += [
        rec(0x1029, "Error behaviour", [
            count(2, "Number of entries"),
            Sub(1, "Communication error", U8, "rw", 0, low=0, high=2),
            Sub(2, "Internal device error", U8, "rw", 0, low=0, high=2)], "ARRAY"),
        # E§4.3 manufacturer area
        var(0x2000, "Node-ID", U8, "rw", 0x7F, low=1, high=127),
        var(0x2001, "CAN bit rate", U16, "rw"),
        var(0x2002, "Temperature", I16, "ro", pdo=1),
        var(0x2003, "Supply voltage", U16, "ro", pdo=1),
        rec(0x2010, "Filter position and speed", [
            count(2, "Number of available channels"),
            Sub(1, "Filter position", U8, "rw", 0, low=0, high=7),
            Sub(2, "Filter speed", U8, "rw", 3, low=0, high=8)]),
        var(0x2100, "Position error reset", BOOL, "wo", 1),
        var(0x2101, "Power management", BOOL, "wo", 1),
        var(0x2104, "EMCY behaviour", U8, "rw", 0, low=0, high=3),
        rec(0x2300, "Settings and reset commands", [
            count(6, "Number of available entries"),
            Sub(1, "Reset maintenance", BOOL, "wo", 1),
            Sub(2, "Reset lot size", BOOL, "wo", 1),
            Sub(3, "Reset temperature minimum", BOOL, "wo", 1),
            Sub(4, "Reset temperature maximum", BOOL, "wo", 1),
            Sub(5, "Reset voltage minimum", BOOL, "wo", 1),
            Sub(6, "Reset voltage maximum", BOOL, "wo", 1)]),
        var(0x230A, "Time between maintenance", U32, "rw", 0x0000FFFF),
        rec(0x2310, "Boot cycles counter", [
            count(2, "Number of available entries"),
            Sub(1, "Boot cycles since maintenance", U32, "ro"),
            Sub(2, "Boot cycles total", U32, "ro")]),
        rec(0x2320, "Operating time counter", [
            count(3, "Number of available entries"),
            Sub(1, "Operating time since power-on", U32, "ro"),
            Sub(2, "Operating time since maintenance", U32, "ro"),
            Sub(3, "Operating time total", U32, "ro")]),
        var(0x232A, "Time counter unit", U16, "ro", 6),
        rec(0x2330, "Lot size counter", [
            count(4, "Number of available entries"),
            Sub(1, "Lot size since power-on", U32, "ro"),
            Sub(2, "Lot size since reset", U32, "ro", pdo=1),
            Sub(3, "Lot size since maintenance", U32, "ro"),
            Sub(4, "Lot size total", U32, "ro")]),
        var(0x233A, "Lot size config", U8, "rw", 0, low=0, high=4),
        rec(0x2340, "Odometer", [
            count(3, "Number of available entries"),
            Sub(1, "Odometer since power-on", U32, "ro"),
            Sub(2, "Odometer since maintenance", U32, "ro"),
            Sub(3, "Odometer total", U32, "ro")]),
        var(0x234A, "Odometer unit", U16, "ro"),
    ]
    for idx, what, dtype in ((0x2350, "Temperature", I16), (0x2360, "Voltage", U16)):
        subs = [count(9, "Number of available entries"), Sub(1, "%s live" % what, dtype, "ro")]
        n = 2
        for window in ("power-on", "reset", "maintenance", "total"):
            for edge in ("minimum", "maximum"):
                subs.append(Sub(n, "%s %s %s" % (what, edge, "total" if window == "total" else "since " + window),
                                dtype, "ro"))
                n += 1
        objs.append(rec(idx, what, subs))
        objs.append(rec(idx + 0xA, "%s thresholds (user-set)" % what, [
            count(2, "Number of available entries"),
            Sub(1, "%s warning minimum" % what, dtype, "rw"),
            Sub(2, "%s warning maximum" % what, dtype, "rw")]))
        objs.append(rec(idx + 0xB, "%s thresholds (factory-set)" % what, [
            count(2, "Number of available entries"),
            Sub(1, "%s threshold minimum" % what, dtype, "ro"),
            Sub(2, "%s threshold maximum" % what, dtype, "ro")]))
    # E§4.2 device profile area
    objs += [
        var(0x6000, "Operating parameters", U8, "rw", 0),
        var(0x6001, "Measuring units per revolution", U32, "rw", 0x00010000),
        var(0x6002, "Total measuring range in measuring units", U32, "rw", 0x002C0000),
        var(0x6003, "Preset value", U32, "rw", 0),
        var(0x6004, "Position value", I32, "ro", 0, pdo=1),
        var(0x600C, "Position raw value", U32, "ro", 0, pdo=1),
        channels(0x6020, "Position value (alias of 0x6004)", 1, "Position value channel {ch} (alias of 0x6004)",
                 I32, "ro", 0, pdo=1),
        channels(0x6030, "Speed value", 1, "Speed value channel {ch}", I16, "ro", 0, pdo=1),
        rec(0x6031, "Speed parameter", [
            count(2, "Number of entries"),
            Sub(1, "Speed source selector", U8, "rw", 2),
            Sub(2, "Speed integration time", U16, "rw", 1, low=0, high=25)]),
        channels(0x6300, "CAM state register", 1, "CAM state channel {ch}", U8, "ro", 0, pdo=1),
        channels(0x6301, "CAM enable register", 1, "CAM enable channel {ch}", U8, "rw", 0),
        channels(0x6302, "CAM polarity register", 1, "CAM polarity channel {ch}", U8, "rw", 0),
    ]
    for cam in range(4):
        objs.append(channels(0x6310 + cam, "CAM%d low limit" % (cam + 1), 1,
                             "CAM%d low limit channel {ch}" % (cam + 1), I32, "rw", 0))
        objs.append(channels(0x6320 + cam, "CAM%d high limit" % (cam + 1), 1,
                             "CAM%d high limit channel {ch}" % (cam + 1), I32, "rw", 0x002BFFFF))
        objs.append(channels(0x6330 + cam, "CAM%d hysteresis" % (cam + 1), 1,
                             "CAM%d hysteresis channel {ch}" % (cam + 1), U16, "rw", 0))
    objs += [
        channels(0x6400, "Work area state register", 1, "Work area state channel {ch}", U8, "ro", 0, pdo=1,
                 sub0_name="Number of available work areas"),
        channels(0x6401, "Work area low limit", 1, "Work area low limit {ch}", I32, "rw", 0,
                 sub0_name="Number of available work areas"),
        channels(0x6402, "Work area high limit", 1, "Work area high limit {ch}", I32, "rw", 0x002BFFFF),
        var(0x6500, "Operating status", U16, "ro", 0),
        var(0x6501, "Measuring units per revolution (physical)", U32, "ro", 0x00010000),
        var(0x6502, "Number of distinguishable revolutions", U16, "ro", 0x002C),
        var(0x6503, "Alarms", U16, "ro", 0, pdo=1),
        var(0x6504, "Supported alarms", U16, "ro", 0xC002),
        var(0x6505, "Warnings", U16, "ro", 0, pdo=1),
        var(0x6506, "Supported warnings", U16, "ro", 0xC05C),
        var(0x6507, "Profile and software version", U32, "ro"),
        var(0x6508, "Operating time", U32, "ro"),
        var(0x6509, "Offset value", I32, "ro", 0),
        rec(0x650A, "Module identification", [
            count(3, "Number of entries"),
            Sub(1, "Manufacturer offset value", I32, "ro", 0),
            Sub(2, "Manufacturer min position value", I32, "ro", 0),
            Sub(3, "Manufacturer max position value", I32, "ro", 0x002BFFFF)]),
        var(0x650B, "Serial number", U32, "ro"),
        var(0x650D, "Absolute accuracy", U8, "ro", 0x10),
        var(0x650E, "Device capability", U16, "ro", 0x0003),
    ]
    return objs


def multiturn_file():
    name = "novotechnik-multiturn.eds"
    info = device_info("Novotechnik Messwertaufnehmer OHG", NOVOTECHNIK,
                       "Multiturn series MZ1-2200/MC1-2800/MB1-3600", MULTITURN_PRODUCT, (50, 125, 250, 500, 800, 1000))
    cobridge = [("Family", family_name("novotechnik_multiturn")),
                ("AdditionalProductNumbers", ",".join("0x%04X" % p for p in MULTITURN_PRE_V03_PRODUCTS))]
    header = MULTITURN_HEADER.format(vendor=NOVOTECHNIK, product=MULTITURN_PRODUCT, mz=MULTITURN_PRE_V03_PRODUCTS[0],
                                     mc=MULTITURN_PRE_V03_PRODUCTS[1], mb=MULTITURN_PRE_V03_PRODUCTS[2])
    return name, render(header.split("\n"), name, "Novotechnik multiturn series with condition monitoring",
                        info, cobridge, multiturn_objects())


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description="Writes the CiA 306 EDS files of the three device families.")
    ap.add_argument("out_dir", nargs="?", default=os.path.join(here, "..", "config", "devices"),
                    help="where to write the .eds files (default: config/devices)")
    out_dir = ap.parse_args().out_dir
    # An option-like directory name is a mistyped option, never an output
    # folder: '--help' once wrote twelve EDS files into ./--help/.
    if os.path.basename(os.path.normpath(out_dir)).startswith("-"):
        ap.error("output directory '%s' looks like an option" % out_dir)
    os.makedirs(out_dir, exist_ok=True)
    files = list(rotary_files()) + [ifm_file(), multiturn_file()]
    for name, text in files:
        with open(os.path.join(out_dir, name), "w", newline="") as f:
            f.write(text + "\n")
        print("wrote", os.path.join(out_dir, name))


if __name__ == "__main__":
    main()
