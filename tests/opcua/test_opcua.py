# SPDX-License-Identifier: MIT
"""The OPC UA side end to end (docs/opcua.md): drsim, drgatewayd with
[opcua] on loopback, and python asyncua as the plant's client. The robot's
own view comes from drcli get against drsim, not from the gateway."""
import asyncio
import datetime
import signal
import socket
import struct
import subprocess

import pytest
from asyncua import ua

import ualib
from gwlib import DRGATEWAYD, EXIT_CONFIG, EXIT_OK, LOGDIR, drcli_identity, timeout, wait_for
from ualib import O2T, T2O, client, drcli_get, f32, gateway, node, ns_of, read, run

JOINTS = ["joint_state.position[%d]" % i for i in range(1, 7)]


@pytest.fixture(scope="module")
def still():
    """A robot that stands still (reads can be compared exactly), writes on."""
    with gateway("ua_still") as g:
        yield g


def test_browse_flat_view(still):
    """Objects/drgate/r0 holds one variable per field element, named by its
    canonical path: the paths drcli get prints for the same robot."""
    want = set(drcli_get(still.sim, *(T2O + O2T)))
    assert len(want) > 300

    async def browse():
        async with client(still.url) as c:
            ns = await ns_of(c)
            root = await c.nodes.objects.get_child("%d:drgate" % ns)
            robots = [(await n.read_browse_name()).Name for n in await root.get_children()]
            r0 = await root.get_child("%d:r0" % ns)
            names = set()
            for n in await r0.get_children():
                bn = await n.read_browse_name()
                assert bn.NamespaceIndex == ns
                assert n.nodeid == ua.NodeId("r0/" + bn.Name, ns)
                names.add(bn.Name)
            return robots, names
    robots, names = run(browse())
    assert robots == ["r0"]
    assert names == want


def test_sessions_in_the_summary_arrays_only(still):
    """No object per session (nor per subscription) in the address space:
    open62541 builds some 60 nodes for each CreateSession, before any
    login, in the daemon's loop (docs/opcua.md "Security"). A session's
    object is there without children; the session's diagnostics are read
    from SessionsDiagnosticsSummary's SessionDiagnosticsArray, and its
    subscription from ServerDiagnostics' SubscriptionDiagnosticsArray."""
    O = ua.ObjectIds

    async def look():
        async with client(still.url) as c:
            sub = await c.create_subscription(100, None)
            summary = c.get_node(O.Server_ServerDiagnostics_SessionsDiagnosticsSummary)
            arrays = {O.Server_ServerDiagnostics_SessionsDiagnosticsSummary_SessionDiagnosticsArray,
                      O.Server_ServerDiagnostics_SessionsDiagnosticsSummary_SessionSecurityDiagnosticsArray}
            objects = [n for n in await summary.get_children()
                       if n.nodeid.Identifier not in arrays or n.nodeid.NamespaceIndex != 0]
            children = [len(await n.get_children()) for n in objects]
            sessions = await c.get_node(
                O.Server_ServerDiagnostics_SessionsDiagnosticsSummary_SessionDiagnosticsArray
            ).read_value()
            subs = await c.get_node(
                O.Server_ServerDiagnostics_SubscriptionDiagnosticsArray).read_value()
            await sub.delete()
            return children, sessions, subs, sub.subscription_id
    children, sessions, subs, sub_id = run(look())
    assert children and all(n == 0 for n in children), children
    assert len(sessions) == len(children) >= 1
    assert any(s.SubscriptionId == sub_id for s in subs)


def test_types_units_enum_access(still):
    """Boolean, Byte, Int32, Float by the field's kind; EngineeringUnits
    (UNECE codes) on fields with a unit; robot_state's EnumStrings; T->O
    read-only, O->T writable."""
    async def look():
        async with client(still.url) as c:
            out = {}
            for p in ("joint_state.position[1]", "io_state.servo_on", "int_in[0]",
                      "io_state.robot_state", "io_state.version.major", "float_in[3]",
                      "joint_state.motor_temperature[2]", "bit_in[5]"):
                n = await node(c, "r0", p)
                out[p] = (await n.read_data_type(), await n.read_attribute(
                    ua.AttributeIds.AccessLevel))
            pos = await node(c, "r0", "joint_state.position[1]")
            eu = await (await pos.get_child("0:EngineeringUnits")).read_value()
            temp = await node(c, "r0", "joint_state.motor_temperature[2]")
            eu_t = await (await temp.get_child("0:EngineeringUnits")).read_value()
            st = await node(c, "r0", "io_state.robot_state")
            names = await (await st.get_child("0:EnumStrings")).read_value()
            st_type = await st.read_type_definition()
            return out, eu, eu_t, names, st_type
    out, eu, eu_t, names, st_type = run(look())
    types = {p: v[0] for p, v in out.items()}
    assert types["joint_state.position[1]"] == ua.NodeId(ua.ObjectIds.Float)
    assert types["io_state.servo_on"] == ua.NodeId(ua.ObjectIds.Boolean)
    assert types["int_in[0]"] == ua.NodeId(ua.ObjectIds.Int32)
    assert types["io_state.robot_state"] == ua.NodeId(ua.ObjectIds.Byte)
    assert types["io_state.version.major"] == ua.NodeId(ua.ObjectIds.Byte)
    assert types["float_in[3]"] == ua.NodeId(ua.ObjectIds.Float)
    assert types["bit_in[5]"] == ua.NodeId(ua.ObjectIds.Boolean)
    # degree: UNECE "DD", degree Celsius: "CEL" (OPC UA Part 8's UnitId)
    assert eu.NamespaceUri == "http://www.opcfoundation.org/UA/units/un/cefact"
    assert eu.UnitId == (ord("D") << 8) | ord("D")
    assert eu_t.UnitId == (ord("C") << 16) | (ord("E") << 8) | ord("L")
    assert [t.Text for t in names][:9] == ["INITIALIZING", "STANDBY", "OPERATING", "SAFE_OFF",
                                          "TEACHING", "SAFE_STOP", "EMERGENCY_STOP", "HOMING",
                                          "RECOVERY"]
    assert st_type == ua.NodeId(ua.ObjectIds.MultiStateDiscreteType)
    access = {p: v[1].Value.Value for p, v in out.items()}
    rw = ua.AccessLevel.CurrentRead.mask | ua.AccessLevel.CurrentWrite.mask
    assert access["joint_state.position[1]"] == ua.AccessLevel.CurrentRead.mask
    assert access["int_in[0]"] & rw == rw
    assert access["bit_in[5]"] & rw == rw


def test_read_equals_drcli(still):
    """Every T->O value read over OPC UA equals the robot's own (drcli get
    against drsim; --still: nothing moves), with status Good and the
    packet's source timestamp. (A robot still booting changes a few
    fields: the OPC UA read is taken between two equal drcli reads.)"""
    want = drcli_get(still.sim, *T2O)

    async def read_all():
        async with client(still.url) as c:
            ns = await ns_of(c)
            paths = sorted(want)
            nodes = [c.get_node(ua.NodeId("r0/" + p, ns)) for p in paths]
            dvs = []
            for i in range(0, len(nodes), 50):
                params = ua.ReadParameters()
                params.TimestampsToReturn = ua.TimestampsToReturn.Both
                for n in nodes[i:i + 50]:
                    rv = ua.ReadValueId()
                    rv.NodeId = n.nodeid
                    rv.AttributeId = ua.AttributeIds.Value
                    params.NodesToRead.append(rv)
                dvs += await c.uaclient.read(params)
            return dict(zip(paths, dvs))
    for _ in range(20):
        got = run(read_all())
        again = drcli_get(still.sim, *T2O)
        if again == want:
            break
        want = again
    else:
        pytest.fail("the robot's values never stood still between two reads")
    now = datetime.datetime.now(datetime.timezone.utc)
    for p, dv in got.items():
        assert dv.StatusCode.is_good(), (p, dv.StatusCode)
        v = dv.Value.Value
        if isinstance(want[p], float):
            assert v == f32(want[p]), p
        else:
            assert v == want[p], p
        assert dv.SourceTimestamp is not None, p
        ts = dv.SourceTimestamp.replace(tzinfo=datetime.timezone.utc)
        assert abs((now - ts).total_seconds()) < 60, (p, ts)


def test_t2o_write_refused(still):
    """A write to a T->O variable: BadNotWritable, the robot unchanged."""
    assert refused_write(still.url, "joint_state.position[1]",
                         ua.Variant(12.5, ua.VariantType.Float)) == ua.StatusCodes.BadNotWritable
    assert refused_write(still.url, "int_out[0]") == ua.StatusCodes.BadNotWritable
    assert drcli_get(still.sim, "int_out[0]")["int_out[0]"] == \
        drcli_get(still.sim, "int_in[0]")["int_in[0]"]


def test_write_echoes_through_the_robot(still):
    """int_in[0] written over OPC UA goes through the write path to the
    robot, which echoes it to int_out[0] (drsim), read back over OPC UA; the
    write log names the OPC UA session."""
    mark = len(still.log())

    async def write_and_wait():
        async with client(still.url) as c:
            w = await node(c, "r0", "int_in[0]")
            await w.write_value(ua.DataValue(ua.Variant(-123456, ua.VariantType.Int32)))
            r = await node(c, "r0", "int_out[0]")
            for _ in range(int(200 * ualib.gwlib.SCALE)):
                if await r.read_value() == -123456:
                    return True
                await asyncio.sleep(0.05)
            return False
    assert run(write_and_wait())
    assert drcli_get(still.sim, "int_out[0]")["int_out[0]"] == -123456
    still.log_wait("write by opcua session", 10, mark)


def test_wrong_type_refused(still):
    assert refused_write(still.url, "int_in[1]", ua.Variant("12", ua.VariantType.String)) in \
        (ua.StatusCodes.BadTypeMismatch, ua.StatusCodes.BadWriteNotSupported)


def refused_write(url, path="int_in[0]", variant=None):
    """The status code a write of variant (Int32 5) to r0's path is
    refused with."""
    async def w():
        async with client(url) as c:
            with pytest.raises(ua.UaStatusCodeError) as e:
                await (await node(c, "r0", path)).write_value(
                    ua.DataValue(variant or ua.Variant(5, ua.VariantType.Int32)))
            return e.value.code
    return run(w())


def test_writes_off_and_single_writer():
    """writes = no: O->T variables are read-only; single-writer mode: the
    outputs belong to the Modbus writer, an OPC UA write is refused."""
    with gateway("ua_ro", opcua="") as g:
        assert refused_write(g.url) == ua.StatusCodes.BadNotWritable
    with gateway("ua_single", modbus="single_writer = yes") as g:
        assert refused_write(g.url) == ua.StatusCodes.BadUserAccessDenied
        assert drcli_get(g.sim, "int_out[0]")["int_out[0]"] == 0


def test_subscription_with_source_timestamps():
    """A subscription to the six joints (drsim moving) gets changes with
    the packets' source timestamps, growing."""
    with gateway("ua_sub", sim_args=()) as g:
        async def subscribe():
            got = []

            class Handler:
                def datachange_notification(self, n, val, data):
                    got.append((n.nodeid.Identifier, data.monitored_item.Value))

            async with client(g.url) as c:
                nodes = [await node(c, "r0", p) for p in JOINTS]
                sub = await c.create_subscription(10, Handler())
                await sub.subscribe_data_change(nodes, sampling_interval=10)
                for _ in range(int(600 * ualib.gwlib.SCALE)):
                    if len([x for x in got if x[0] == "r0/" + JOINTS[0]]) >= 20:
                        break
                    await asyncio.sleep(0.05)
                await sub.delete()
            return got
        got = run(subscribe(), 90)
    first = [dv for ident, dv in got if ident == "r0/" + JOINTS[0]]
    assert len(first) >= 20
    values = [dv.Value.Value for dv in first]
    assert len(set(values)) >= 10  # changes, not repeats
    stamps = [dv.SourceTimestamp for dv in first]
    assert all(s is not None for s in stamps)
    assert all(a < b for a, b in zip(stamps, stamps[1:]))
    assert all(dv.StatusCode.is_good() for dv in first)


def stamps(url, path):
    """(SourceTimestamp, ServerTimestamp) of r0's path."""
    async def one():
        async with client(url) as c:
            params = ua.ReadParameters()
            params.TimestampsToReturn = ua.TimestampsToReturn.Both
            rv = ua.ReadValueId()
            rv.NodeId = (await node(c, "r0", path)).nodeid
            rv.AttributeId = ua.AttributeIds.Value
            params.NodesToRead.append(rv)
            dv = (await c.uaclient.read(params))[0]
            return dv.SourceTimestamp, dv.ServerTimestamp
    return run(one())


def test_link_loss_statuses():
    """drsim killed: T->O values go UncertainLastUsableValue (O->T ones stay
    Good) with the last packet's source timestamp; drsim back on the same
    ports: Good again."""
    with gateway("ua_loss") as g:
        def status(path):
            async def one():
                async with client(g.url) as c:
                    return (await read(c, "r0", path)).StatusCode.value
            return run(one())
        assert status(JOINTS[0]) == ua.StatusCodes.Good
        g.sim.kill()
        wait_for(lambda: status(JOINTS[0]) == ua.StatusCodes.UncertainLastUsableValue, 30,
                 "joint 1 Uncertain")
        assert status("int_in[0]") == ua.StatusCodes.Good
        # the source timestamp is the last packet's: it stands still while
        # the server's own goes on
        first = stamps(g.url, JOINTS[0])
        wait_for(lambda: stamps(g.url, JOINTS[0])[1] > first[1] + datetime.timedelta(
            seconds=0.5), 30, "the server's clock to move on")
        later = stamps(g.url, JOINTS[0])
        assert later[0] == first[0] and later[0] < later[1], (first, later)
        g.sim.start(same_ports=True)
        g.wait_link(True, seconds=60)
        wait_for(lambda: status(JOINTS[0]) == ua.StatusCodes.Good, 30, "joint 1 Good again")


def test_no_data_yet():
    """A robot that never answered: its T->O variables are
    BadNoCommunication, its O->T ones (the gateway's) Good."""
    with gateway("ua_never", sim_start=False) as g:
        async def look():
            async with client(g.url) as c:
                return [(await read(c, "r0", p)).StatusCode.value
                        for p in (JOINTS[0], "io_state.robot_state", "int_in[0]")]
        assert run(look()) == [ua.StatusCodes.BadNoCommunication,
                               ua.StatusCodes.BadNoCommunication, ua.StatusCodes.Good]
        # who the robot is: not known until its Identity answers
        for where in IDENTIFIED:
            assert identification(g.url, where) == {
                p: (ua.StatusCodes.BadWaitingForInitialData, None) for p in IDENT}, where


def check_config(name, opcua):
    LOGDIR.mkdir(parents=True, exist_ok=True)
    conf = LOGDIR / ("%s.ini" % name)
    conf.write_text("[robot r0]\nhost = 127.0.0.2\n\n[opcua]\n" + opcua)
    p = subprocess.run([str(DRGATEWAYD), "--check-config", str(conf)], capture_output=True,
                       text=True, timeout=timeout(30))
    return p.returncode, p.stdout + p.stderr, conf


def test_check_config_exposure():
    """A non-loopback endpoint with SecurityPolicy None, or without user
    authentication, is refused with FILE:LINE unless insecure = yes."""
    rc, out, conf = check_config("ua_none", "listen = 192.0.2.1\nport = 4840\n")
    assert rc == EXIT_CONFIG
    assert "%s:5: [opcua] listen 192.0.2.1 with security_policies None" % conf in out
    rc, out, conf = check_config("ua_noauth", "cert_file = /x.der\nkey_file = /x.key\n"
                                 "security_policies = Basic256Sha256\nlisten = 192.0.2.1\n")
    assert rc == EXIT_CONFIG
    assert "%s:8: [opcua] listen 192.0.2.1 without auth_file" % conf in out
    rc, out, conf = check_config("ua_insecure", "listen = 192.0.2.1\ninsecure = yes\n")
    assert rc == EXIT_OK, out
    rc, out, conf = check_config("ua_badpol", "security_policies = None, Basic128Rsa15\n")
    assert rc == EXIT_CONFIG
    assert "%s:5: security_policies 'None, Basic128Rsa15' invalid: 'Basic128Rsa15' is no " \
           "policy" % conf in out
    rc, out, conf = check_config("ua_nocert", "security_policies = Basic256Sha256\n")
    assert rc == EXIT_CONFIG
    assert "%s:5: [opcua] security_policies Basic256Sha256 needs cert_file" % conf in out


def test_check_config_trust_dir(tmp_path):
    """trust_dir: refused with FILE:LINE without a secure policy, when it
    is missing, holds a file of another kind, or holds no certificate."""
    secure = "cert_file = /x.der\nkey_file = /x.key\nsecurity_policies = Basic256Sha256\n"
    rc, out, conf = check_config("ua_trust_none", "trust_dir = %s\n" % tmp_path)
    assert rc == EXIT_CONFIG
    assert "%s:5: [opcua] trust_dir needs a secure security_policies" % conf in out
    rc, out, conf = check_config("ua_trust_missing", secure + "trust_dir = %s/no\n" % tmp_path)
    assert rc == EXIT_CONFIG
    assert "%s:8: [opcua] trust_dir %s/no: No such file or directory" % (conf, tmp_path) in out
    (tmp_path / "README").write_text("the plant's clients\n")
    rc, out, conf = check_config("ua_trust_other", secure + "trust_dir = %s\n" % tmp_path)
    assert rc == EXIT_CONFIG
    assert "%s:8: [opcua] trust_dir %s/README: not a certificate" % (conf, tmp_path) in out
    (tmp_path / "README").unlink()
    (tmp_path / "ca.crl").write_text("-----BEGIN X509 CRL-----\nAAAA\n-----END X509 CRL-----\n")
    rc, out, conf = check_config("ua_trust_empty", secure + "trust_dir = %s\n" % tmp_path)
    assert rc == EXIT_CONFIG
    assert "%s:8: [opcua] trust_dir %s holds no certificate" % (conf, tmp_path) in out


def test_reload_keeps_the_robot():
    """SIGHUP with [opcua] unchanged keeps the server and its sessions; a
    new port builds a new server there, the robot's link untouched."""
    with gateway("ua_reload") as g:
        async def session_over_reload():
            async with client(g.url) as c:
                before = (await read(c, "r0", JOINTS[2])).Value.Value
                mark = len(g.log())
                g.signal(signal.SIGHUP)
                g.log_wait("reloaded (generation", 20, mark)
                await asyncio.sleep(0)  # the same session, after the reload
                return before, (await read(c, "r0", JOINTS[2])).Value.Value
        assert run(session_over_reload()) == (90.0, 90.0)
        old = g.ua_port
        g.ua_port = ualib.free_port(ualib.GW_ADDR, udp=False)
        g.extra = g.extra.replace("port = %d\n" % old, "port = %d\n" % g.ua_port)
        g.url = "opc.tcp://%s:%d" % (ualib.GW_ADDR, g.ua_port)
        g.write_config()
        mark = len(g.log())
        g.signal(signal.SIGHUP)
        g.log_wait("opcua: listening on %s" % g.url, 20, mark)

        async def one():
            async with client(g.url) as c:
                return (await read(c, "r0", JOINTS[2])).Value.Value
        assert run(one()) == 90.0
        assert "link down" not in g.log()[mark:]


def test_robotics_view(still):
    """The Robotics companion view (OPC 40010-1): DeviceSet/r0 a
    MotionDeviceSystem with its mandatory members; six axes whose
    ActualPosition is the robot's joint position (Double, degree), the
    motors' temperatures, the controller's software revision from
    io_state.version, the safety state's stops from the state flags; what
    the assemblies do not carry there with BadNotSupported."""
    robot = drcli_get(still.sim, "joint_state", "io_state")

    async def look():
        async with client(still.url) as c:
            di = await c.get_namespace_index(ualib.NS_DI)
            rb = await c.get_namespace_index(ualib.NS_ROBOTICS)
            ns = await ns_of(c)
            ds = await c.nodes.objects.get_child("%d:DeviceSet" % di)
            system = await ds.get_child("%d:r0" % ns)
            out = {"system_type": await system.read_type_definition()}

            async def at(*names):
                return await system.get_child(list(names))

            md = await at("%d:MotionDevices" % rb, "%d:Manipulator" % ns)
            out["md_type"] = await md.read_type_definition()
            for p in ("Manufacturer", "Model", "ProductCode", "SerialNumber"):
                out[p] = (await (await md.get_child("%d:%s" % (di, p))).read_data_value(
                    raise_on_bad_status=False)).StatusCode.value
            out["category"] = await (await md.get_child("%d:MotionDeviceCategory" % rb)).read_value()
            out["speed"] = (await (await md.get_child(["%d:ParameterSet" % di,
                                                        "%d:SpeedOverride" % rb])).read_data_value(
                raise_on_bad_status=False)).StatusCode.value
            out["axes"] = []
            for i in range(1, 7):
                ax = await md.get_child(["%d:Axes" % rb, "%d:Axis%d" % (rb, i)])
                pos = await ax.get_child(["%d:ParameterSet" % di, "%d:ActualPosition" % rb])
                eu = await (await pos.get_child("0:EngineeringUnits")).read_value()
                temp = await md.get_child(["%d:PowerTrains" % rb, "%d:PowerTrain%d" % (rb, i),
                                           "%d:Motor" % rb, "%d:ParameterSet" % di,
                                           "%d:MotorTemperature" % rb])
                out["axes"].append((await ax.read_type_definition(), await pos.read_value(),
                                    (await pos.read_data_type()), eu.UnitId,
                                    await temp.read_value()))
            sw = await at("%d:Controllers" % rb, "%d:Controller" % ns, "%d:Software" % rb,
                          "%d:Firmware" % ns, "%d:SoftwareRevision" % di)
            out["revision"] = await sw.read_value()
            ps = await at("%d:SafetyStates" % rb, "%d:SafetyState" % ns, "%d:ParameterSet" % di)
            out["estop"] = await (await ps.get_child("%d:EmergencyStop" % rb)).read_value()
            out["pstop"] = await (await ps.get_child("%d:ProtectiveStop" % rb)).read_value()
            out["mode"] = (await (await ps.get_child("%d:OperationalMode" % rb)).read_data_value(
                raise_on_bad_status=False)).StatusCode.value
            return out, rb
    out, rb = run(look())
    assert out["system_type"] == ua.NodeId(1002, rb)  # MotionDeviceSystemType
    assert out["md_type"] == ua.NodeId(1004, rb)      # MotionDeviceType
    for p in IDENT:  # the robot's Identity (test_identity_equals_drcli)
        assert out[p] == ua.StatusCodes.Good, p
    assert out["category"] == 1  # ARTICULATED_ROBOT
    assert out["speed"] == ua.StatusCodes.BadNotSupported
    for i, (ty, pos, dt, unit, temp) in enumerate(out["axes"], 1):
        assert ty == ua.NodeId(16601, rb)  # AxisType
        assert dt == ua.NodeId(ua.ObjectIds.Double)
        assert pos == f32(robot["joint_state.position[%d]" % i])
        assert unit == (ord("D") << 8) | ord("D")
        assert temp == f32(robot["joint_state.motor_temperature[%d]" % i])
    assert out["revision"] == "%d.%d.%d" % (robot["io_state.version.major"],
                                            robot["io_state.version.minor"],
                                            robot["io_state.version.patch"])
    assert out["estop"] == robot["io_state.emergency_stopped"]
    assert out["pstop"] == robot["io_state.safety_stopped"]
    assert out["mode"] == ua.StatusCodes.BadNotSupported


# ---- the robot's Identity ---------------------------------------------------------

IDENT = ("Manufacturer", "Model", "ProductCode", "SerialNumber")
# the objects of the Robotics view that carry the robot's Identity
IDENTIFIED = ("MotionDevices/Manipulator", "Controllers/Controller")


def identification(url, where="MotionDevices/Manipulator"):
    """DI's identification of r0's object `where` in the Robotics view:
    {name: (status code, value)}, LocalizedTexts by their text."""
    async def look():
        async with client(url) as c:
            out = {}
            for p in IDENT:
                dv = await read(c, "r0", "rb/%s/%s" % (where, p))
                v = dv.Value.Value if dv.Value is not None else None
                out[p] = (dv.StatusCode.value, v.Text if isinstance(v, ua.LocalizedText) else v)
            return out
    return run(look())


def expected(ident, vendor_name):
    """The identification the robot's Identity (drcli's) makes, as DI types
    it: LocalizedText Manufacturer and Model, String ProductCode and
    SerialNumber (the serial as drcli identity prints it)."""
    good = ua.StatusCodes.Good
    return {"Manufacturer": (good, vendor_name), "Model": (good, ident["product_name"]),
            "ProductCode": (good, str(ident["product_code"])),
            "SerialNumber": (good, "0x%08x" % ident["serial"])}


def test_identity_equals_drcli(still):
    """MotionDevice's and Controller's Manufacturer, Model, ProductCode and
    SerialNumber are the robot's Identity object as drcli identity reads
    it; a vendor ID ODVA gives no name the gateway knows is "vendor N"
    (drsim's 65535). Before: BadNotSupported."""
    want = expected(drcli_identity(still.sim), "vendor 65535")
    for where in IDENTIFIED:
        wait_for(lambda: identification(still.url, where) == want, 20,
                 "%s's identification: %s" % (where, want))


def test_identity_follows_the_robot():
    """Doosan Robotics' vendor ID (1573) gives its name; a robot restarted
    behind the same address with another serial number is read again
    after the new session, and its identity is logged."""
    with gateway("ua_ident", sim_args=("--still", "--vendor-id", "1573")) as g:
        first = drcli_identity(g.sim)
        wait_for(lambda: identification(g.url) == expected(first, "Doosan Robotics"), 20,
                 "the first robot's identification")
        g.sim.kill()
        g.wait_link(False, seconds=30)
        g.sim.extra += ["--seed", "5"]  # another serial number
        g.sim.start(same_ports=True)
        g.wait_link(True, seconds=60)
        second = drcli_identity(g.sim)
        assert second["serial"] != first["serial"]
        wait_for(lambda: identification(g.url) == expected(second, "Doosan Robotics"), 20,
                 "the second robot's identification")
        assert g.log().count("robot r0: identity: Doosan Robotics, '%s' (product code %d, "
                             "revision %s, serial 0x%08x)" % (
                                 second["product_name"], second["product_code"],
                                 second["revision"], second["serial"])) == 1


def test_identity_refused():
    """A robot that refuses Get_Attributes_All on its Identity: the four
    read BadNotSupported, the link is up and its data Good."""
    with gateway("ua_noident", sim_args=("--still", "--refuse-identity")) as g:
        g.log_wait("Identity object (Get_Attributes_All, class 1, instance 1): CIP 0x08", 20)
        for where in IDENTIFIED:
            assert identification(g.url, where) == {
                p: (ua.StatusCodes.BadNotSupported, None) for p in IDENT}, where

        async def joint():
            async with client(g.url) as c:
                return (await read(c, "r0", JOINTS[0])).StatusCode.value
        assert run(joint()) == ua.StatusCodes.Good
        assert "link down" not in g.log()


# ---- SafetyStates -----------------------------------------------------------------

def safety(url):
    """(EmergencyStop, ProtectiveStop) of r0's SafetyState and the flat
    view's io_state.robot_state."""
    async def look():
        async with client(url) as c:
            ps = "rb/SafetyStates/SafetyState/ParameterSet/"
            return tuple([(await read(c, "r0", ps + p)).Value.Value
                          for p in ("EmergencyStop", "ProtectiveStop")] +
                         [(await read(c, "r0", "io_state.robot_state")).Value.Value])
    return run(look())


def test_safety_states_follow_the_robot():
    """drsim's emergency stop (SIGUSR1) and protective stop (SIGUSR2), raised
    and cleared: SafetyState's EmergencyStop and ProtectiveStop follow the
    robot's emergency_stopped and safety_stopped flags, and the flat view's
    robot_state agrees (6 EMERGENCY_STOP, 5 SAFE_STOP, 2 OPERATING)."""
    with gateway("ua_safety") as g:
        wait_for(lambda: safety(g.url) == (False, False, 2), 30, "the robot operating")
        for sig, raised in ((signal.SIGUSR1, (True, False, 6)),
                            (signal.SIGUSR2, (False, True, 5))):
            g.sim.proc.send_signal(sig)
            wait_for(lambda: safety(g.url) == raised, 20, "%s raised: %s" % (sig.name, raised))
            g.sim.proc.send_signal(sig)
            wait_for(lambda: safety(g.url) == (False, False, 2), 20, "%s cleared" % sig.name)


def hello_ack(url, port):
    """A raw OPC UA Hello asking for no limits; the Acknowledge's
    (receive buffer, send buffer, max message size, max chunk count)."""
    endpoint = url.encode()
    body = struct.pack("<IIIII", 0, 65536, 65536, 0, 0) + struct.pack("<i", len(endpoint)) + endpoint
    with socket.create_connection(("127.0.0.1", port), timeout=timeout(10)) as s:
        s.sendall(b"HELF" + struct.pack("<I", 8 + len(body)) + body)
        head = b""
        while len(head) < 8:
            head += s.recv(8 - len(head))
        assert head[:4] == b"ACKF", head
        rest = b""
        while len(rest) < struct.unpack("<I", head[4:])[0] - 8:
            rest += s.recv(64)
    return struct.unpack("<IIIII", rest[:20])[1:]


def test_limits(still):
    """What one client may ask of the daemon's loop at once (docs/opcua.md
    "Limits"): open62541 runs a request whole in the loop and by default
    limited neither a message's size nor a call's nodes (one Read of
    100000 nodes held the loop some 30 ms). The server acknowledges a
    Hello with a 2 MiB message limit; OperationLimits say 1000 nodes a
    call; a Read of 1001 is refused with BadTooManyOperations, of 1000
    answered; the robot's link stays up."""
    recv, send, max_msg, chunks = hello_ack(still.url, still.ua_port)
    assert max_msg == 2 << 20, max_msg
    O = ua.ObjectIds

    async def go():
        async with client(still.url) as c:
            lim = {}
            for name in ("MaxNodesPerRead", "MaxNodesPerWrite", "MaxNodesPerBrowse",
                         "MaxMonitoredItemsPerCall"):
                lim[name] = await c.get_node(
                    getattr(O, "Server_ServerCapabilities_OperationLimits_" + name)).read_value()
            ns = await ns_of(c)

            def params(n):
                p = ua.ReadParameters()
                for i in range(n):
                    rv = ua.ReadValueId()
                    rv.NodeId = ua.NodeId("r0/" + JOINTS[i % 6], ns)
                    rv.AttributeId = ua.AttributeIds.Value
                    p.NodesToRead.append(rv)
                return p
            got = await c.uaclient.read(params(1000))
            with pytest.raises(ua.UaStatusCodeError) as e:
                await c.uaclient.read(params(1001))
            return lim, got, e.value.code
    lim, got, code = run(go())
    assert lim == {"MaxNodesPerRead": 1000, "MaxNodesPerWrite": 1000, "MaxNodesPerBrowse": 1000,
                   "MaxMonitoredItemsPerCall": 1000}, lim
    assert len(got) == 1000 and all(dv.StatusCode.is_good() for dv in got)
    assert code == ua.StatusCodes.BadTooManyOperations
    assert "link up" in still.log_path.read_text()
    assert "no packet from the robot" not in still.log_path.read_text()


def test_max_monitored_items():
    """max_monitored_items counts the items of every session together (each
    is sampled in the daemon's loop): 20 items in two sessions, the next
    one refused with BadTooManyMonitoredItems, room again when one goes."""
    with gateway("ua_items", opcua="max_monitored_items = 20") as g:
        async def go():
            async with client(g.url) as a, client(g.url) as b:
                ns = await ns_of(a)
                sa = await a.create_subscription(100, None)
                sb = await b.create_subscription(100, None)
                nodes_a = [a.get_node(ua.NodeId("r0/" + JOINTS[i % 6], ns)) for i in range(12)]
                nodes_b = [b.get_node(ua.NodeId("r0/" + JOINTS[i % 6], ns)) for i in range(9)]
                handles = await sa.subscribe_data_change(nodes_a)
                assert all(isinstance(h, int) for h in handles), handles
                got = await sb.create_monitored_items([
                    ua.MonitoredItemCreateRequest(
                        ItemToMonitor=ua.ReadValueId(NodeId=n.nodeid,
                                                     AttributeId=ua.AttributeIds.Value),
                        MonitoringMode=ua.MonitoringMode.Reporting,
                        RequestedParameters=ua.MonitoringParameters(
                            ClientHandle=100 + i, SamplingInterval=100, QueueSize=1,
                            DiscardOldest=True))
                    for i, n in enumerate(nodes_b)])
                codes = [r if isinstance(r, ua.StatusCode) else None for r in got]
                await sa.unsubscribe(handles[0])
                again = await sb.subscribe_data_change(nodes_b[-1])
                return codes, again
        codes, again = run(go())
    assert codes[:8] == [None] * 8, codes  # 12 + 8 = 20
    assert codes[8] is not None and codes[8].value == ua.StatusCodes.BadTooManyMonitoredItems
    assert isinstance(again, int)
