# SPDX-License-Identifier: MIT
"""drsim against pycomm3, an independent EtherNet/IP originator.

pycomm3 builds every request itself (RegisterSession, SendRRData, UCMM,
Get/Set_Attribute_Single, Unconnected Send, ListIdentity) and parses every
reply; none of our code runs on its side. What passes here is drsim's
explicit messaging as a third-party scanner sees it.
"""
import math
import random
import struct
import time
import unittest

from pycomm3 import CIPDriver, Services
from pycomm3.cip.status_info import SERVICE_STATUS
from pycomm3.custom_types import ModuleIdentityObject

import peers
from peers import ASM, ASSEMBLIES

GET, SET = Services.get_attribute_single, Services.set_attribute_single


class Pycomm3VsDrsim(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.sim = peers.Drsim()
        cls.path = "%s:%d" % (peers.SIM_ADDR, cls.sim.tcp_port)

    @classmethod
    def tearDownClass(cls):
        rc = cls.sim.stop()
        if rc != 0:
            print(cls.sim.log_text())
        cls.sim.cleanup()
        assert rc == 0, "drsim exited with %r" % rc

    def setUp(self):
        self.drv = CIPDriver(self.path)
        self.drv.socket_timeout = 5.0
        self.drv.open()

    def tearDown(self):
        self.drv.close()

    def msg(self, service, inst, attr, data=b"", cls=4, routed=False):
        return self.drv.generic_message(service=service, class_code=cls, instance=inst,
                                        attribute=attr, request_data=data,
                                        connected=False, route_path=routed,
                                        name="%s %d/%d/%d" % (service, cls, inst, attr))

    def get(self, name):
        r = self.msg(GET, ASM[name][0], 3)
        self.assertIsNone(r.error, "%s: %s" % (name, r.error))
        return bytes(r.value)

    def set(self, name, data):
        r = self.msg(SET, ASM[name][0], 3, data)
        self.assertIsNone(r.error, "%s: %s" % (name, r.error))

    def assertStatus(self, r, general):
        self.assertIsNotNone(r.error, "expected CIP status 0x%02X" % general)
        self.assertTrue(r.error.startswith(SERVICE_STATUS[general]),
                        "expected 0x%02X (%s), pycomm3 says %r" % (general, SERVICE_STATUS[general], r.error))

    # ---- every assembly --------------------------------------------------

    def test_get_every_assembly_data_and_size(self):
        for name, inst, _, size in ASSEMBLIES:
            with self.subTest(assembly=name):
                r = self.msg(GET, inst, 3)
                self.assertIsNone(r.error, r.error)
                self.assertEqual(len(r.value), size)
                r = self.msg(GET, inst, 4)  # attribute 4: size in bytes, UINT
                self.assertIsNone(r.error, r.error)
                self.assertEqual(len(r.value), 2)
                self.assertEqual(peers.le_u16(r.value, 0), size)

    def test_routed_through_unconnected_send(self):
        """The same Gets wrapped in Unconnected_Send (0x52) with route 1/0,
        as a PLC sends them."""
        drv = CIPDriver(self.path + "/bp/0")
        drv.socket_timeout = 5.0
        drv.open()
        try:
            for name, inst, _, size in ASSEMBLIES:
                with self.subTest(assembly=name):
                    r = self.msg_on(drv, inst)
                    self.assertIsNone(r.error, r.error)
                    self.assertEqual(len(r.value), size)
        finally:
            drv.close()

    @staticmethod
    def msg_on(drv, inst):
        return drv.generic_message(service=GET, class_code=4, instance=inst, attribute=3,
                                   connected=False, route_path=True)

    # ---- decoded values, read as the specification lays them out ------------

    def test_io_state_values(self):
        io = self.get("io_state")
        self.assertEqual(tuple(io[28:31]), (2, 12, 3), "controller version 2.12.3")
        self.assertLessEqual(io[32], 10, "robot_state within INITIALIZING..SAFE_OFF2")
        self.assertEqual(io[4] & 0xF0, 0, "reserved bits of the aio_type row")
        for off in (8, 12, 16, 20):  # ai[0..1], ao[0..1]
            self.assertTrue(math.isfinite(struct.unpack_from("<f", io, off)[0]))

    def test_joint_and_task_state_values(self):
        js = struct.unpack("<36f", self.get("joint_state"))
        pos, vel, cur, temp = js[0:6], js[6:12], js[12:18], js[18:24]
        self.assertTrue(all(math.isfinite(v) for v in js))
        self.assertTrue(all(-360.0 <= p <= 360.0 for p in pos), pos)
        self.assertTrue(all(abs(v) < 1000.0 for v in vel), vel)
        self.assertTrue(all(abs(c) < 100.0 for c in cur), cur)
        self.assertTrue(all(0.0 < t < 150.0 for t in temp), temp)
        ts = struct.unpack("<24f", self.get("task_state"))
        self.assertTrue(all(math.isfinite(v) for v in ts))
        reach = math.sqrt(ts[0] ** 2 + ts[1] ** 2 + ts[2] ** 2)
        self.assertLess(reach, 2500.0, "TCP within an M1013's reach (mm)")

    def test_identity(self):
        r = self.drv.generic_message(service=Services.get_attributes_all, class_code=1,
                                     instance=1, connected=False, route_path=False,
                                     data_type=ModuleIdentityObject)
        self.assertIsNone(r.error, r.error)
        self.assertTrue(r.value["product_name"].startswith("drsim"))
        li = CIPDriver.list_identity(self.path)
        self.assertIsNotNone(li)
        self.assertEqual(li["product_name"], r.value["product_name"])
        self.assertEqual(li["serial"], r.value["serial"])
        self.assertEqual(li["ip_address"], peers.SIM_ADDR)

    # ---- writes ----------------------------------------------------------

    def test_set_o2t_and_read_back(self):
        rnd = random.Random(3)
        images = {
            # cb_do 1..16, tool_do 1..6, ao_type; ao[0..1]
            "io_control": struct.pack("<I2f", 0xA5C3 | 0x2A << 16 | 0x3 << 24, 4.25, -2.5),
            "bit_in": bytes(rnd.randrange(256) for _ in range(8)),
            "int_in": struct.pack("<24i", *(rnd.randrange(-2**31, 2**31) for _ in range(24))),
            "float_in": struct.pack("<24f", *(rnd.uniform(-1e6, 1e6) for _ in range(24))),
        }
        for name, data in images.items():
            with self.subTest(assembly=name):
                self.assertEqual(len(data), ASM[name][2])
                self.set(name, data)
                self.assertEqual(self.get(name), data)

    def test_echo_to_outputs(self):
        """GPR inputs come back on the outputs (bit_in->bit_out, ...)."""
        rnd = random.Random(11)
        pairs = {
            "bit_in": ("bit_out", bytes(rnd.randrange(256) for _ in range(8))),
            "int_in": ("int_out", struct.pack("<24i", *range(-12, 12))),
            "float_in": ("float_out", struct.pack("<24f", *(i * 0.5 for i in range(24)))),
        }
        for name, (out, data) in pairs.items():
            with self.subTest(assembly=name):
                self.set(name, data)
                self.assertEqual(self.poll(out, lambda b: b == data), data)

    def test_io_control_shows_in_io_state(self):
        self.set("io_control", struct.pack("<I2f", 0x8001 | 0x04 << 16, 1.5, 0.0))
        io = self.poll("io_state", lambda b: b[2:4] == b"\x01\x80")
        self.assertEqual(io[2:4], b"\x01\x80", "cb_do 1 and 16")
        self.assertEqual(io[26] & 0x3F, 0x04, "tool_do 3")
        self.assertEqual(struct.unpack_from("<f", io, 16)[0], 1.5, "ao[0]")

    def poll(self, name, ok, timeout=3.0):
        """Read `name` until ok(data) (the model step is 10 ms), bounded."""
        deadline = time.monotonic() + timeout
        data = self.get(name)
        while not ok(data) and time.monotonic() < deadline:
            time.sleep(0.02)
            data = self.get(name)
        return data

    # ---- refusals, as pycomm3 decodes them ------------------------------------

    def test_errors(self):
        self.assertStatus(self.msg(SET, ASM["int_out"][0], 3, bytes(96)), 0x0E)
        self.assertStatus(self.msg(SET, ASM["float_in"][0], 3, bytes(95)), 0x13)
        self.assertStatus(self.msg(SET, ASM["float_in"][0], 3, bytes(97)), 0x15)
        self.assertStatus(self.msg(GET, 150, 3), 0x05)
        self.assertStatus(self.msg(GET, 101, 9), 0x14)
        # and the session is still fine afterwards
        self.assertEqual(len(self.get("io_state")), 36)


class Pycomm3VsDrsimLayouts(unittest.TestCase):
    """drsim --layout combined and gpr_only (issue 31) as pycomm3 sees them:
    the input point 100 and the output point 150 with their sizes (data and
    attribute 4), the per-assembly instances gone (0x05), the output point
    written and read back, and the bit_in echo in its place in the input."""

    LAYOUTS = {"combined": (476, 212, 36 + 144 + 96, 12),  # sizes, bit_out's
               "gpr_only": (200, 200, 0, 0)}               # and bit_in's place

    def run_layout(self, layout):
        size_in, size_out, bit_out, bit_in = self.LAYOUTS[layout]
        sim = peers.Drsim("--layout", layout)
        drv = CIPDriver("%s:%d" % (peers.SIM_ADDR, sim.tcp_port))
        drv.socket_timeout = 5.0
        drv.open()
        try:
            def msg(service, inst, attr, data=b""):
                return drv.generic_message(service=service, class_code=4, instance=inst,
                                           attribute=attr, request_data=data,
                                           connected=False, route_path=False,
                                           name="%s %d/%d" % (service, inst, attr))
            for inst, size in ((100, size_in), (150, size_out)):
                r = msg(GET, inst, 3)
                self.assertIsNone(r.error, r.error)
                self.assertEqual(len(r.value), size)
                r = msg(GET, inst, 4)
                self.assertIsNone(r.error, r.error)
                self.assertEqual(peers.le_u16(r.value, 0), size)
            r = msg(GET, 101, 3)
            self.assertTrue(r.error and r.error.startswith(SERVICE_STATUS[0x05]), r.error)
            bits = bytes([0xA5, 0x0F, 0, 0x80, 1, 2, 3, 4])
            out = bytearray(size_out)
            out[bit_in:bit_in + 8] = bits
            r = msg(SET, 150, 3, bytes(out))
            self.assertIsNone(r.error, r.error)
            r = msg(GET, 150, 3)
            self.assertEqual(bytes(r.value), bytes(out))
            deadline = time.monotonic() + 5
            while time.monotonic() < deadline:
                img = bytes(msg(GET, 100, 3).value)
                if img[bit_out:bit_out + 8] == bits:
                    break
                time.sleep(0.05)
            self.assertEqual(img[bit_out:bit_out + 8], bits, "bit_in -> bit_out")
        finally:
            drv.close()
            rc = sim.stop()
            sim.cleanup()
        self.assertEqual(rc, 0)

    def test_combined(self):
        self.run_layout("combined")

    def test_gpr_only(self):
        self.run_layout("gpr_only")


if __name__ == "__main__":
    unittest.main()
