"""An independent OPC UA server (python asyncua) standing in for a CNC, for the service's
integration tests (crates/service/tests/integration/opcua_asyncua.rs starts it as a
subprocess; CI installs asyncua from .ci/requirements.txt).

Namespace "urn:gearcomp-asyncua-cnc" holds, as string node ids:
  Temp.A, Temp.B   Double inputs (set from the test with "set NAME VALUE" lines on stdin)
  Comp.D           Double, writable          Comp.F  Float (REAL), writable
  Comp.I16         Int16 (INT), writable     Comp.I32 Int32 (DINT), writable
  Comp.RO          Double, read only         Hold    Boolean, writable
  Beat             Int16, writable
Every change of a writable node is printed as one JSON line
{"node": NAME, "value": V, "type": VARIANT_TYPE}; the first line is
{"ready": true, "ns": INDEX, "server_cert": PATH, "user_cert": PATH, "user_key": PATH}.

--secure offers only Basic256Sha256 Sign and SignAndEncrypt endpoints (no None), with a
user name / password (password from the environment variable named by --password-env) and
an X.509 user certificate login (a certificate generated here, written beside the server's).
Without --secure: security None, anonymous login.
"""

import argparse
import asyncio
import json
import os
import sys
from pathlib import Path

from asyncua import Server, ua
from asyncua.crypto import uacrypto
from asyncua.crypto.cert_gen import setup_self_signed_certificate
from asyncua.crypto.permission_rules import User, UserRole
from cryptography.x509.oid import ExtendedKeyUsageOID

NS_URI = "urn:gearcomp-asyncua-cnc"


class Users:
    """User name + password, or the one user certificate made here."""

    def __init__(self, user, password, cert_der):
        self.user = user
        self.password = password
        self.cert_der = cert_der

    def get_user(self, iserver, username=None, password=None, certificate=None):
        if self.password is None:
            # The unsecured test server: anonymous.
            return User(role=UserRole.Admin)
        # asyncua passes the client's application certificate along with a user-name
        # login, and the (verified) user certificate with an X.509 login.
        if username is not None:
            if username == self.user and password == self.password:
                return User(role=UserRole.Admin, name=username)
            return None
        if certificate is not None and self.cert_der is not None and certificate == self.cert_der:
            return User(role=UserRole.Admin, name="cert-user")
        return None


def emit(obj):
    sys.stdout.write(json.dumps(obj) + "\n")
    sys.stdout.flush()


async def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--port", type=int, required=True)
    ap.add_argument("--dir", required=True, help="where the certificates are written")
    ap.add_argument("--secure", action="store_true")
    ap.add_argument("--user", default="op")
    ap.add_argument("--password-env", default="GC_ASYNCUA_PASSWORD")
    args = ap.parse_args()
    d = Path(args.dir)
    d.mkdir(parents=True, exist_ok=True)

    cert_der = None
    password = None
    server_cert = d / "server_cert.der"
    user_cert = d / "user_cert.der"
    user_key = d / "user_key.pem"
    if args.secure:
        password = os.environ.get(args.password_env)
        if not password:
            sys.exit(f"environment variable {args.password_env} (the password) is not set")
        await setup_self_signed_certificate(
            d / "server_key.pem",
            server_cert,
            "urn:gearcomp-asyncua-cnc-server",
            "127.0.0.1",
            [ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH],
            {"commonName": "gearcomp asyncua test CNC"},
        )
        await setup_self_signed_certificate(
            user_key,
            user_cert,
            "urn:gearcomp-test-user",
            "127.0.0.1",
            [ExtendedKeyUsageOID.CLIENT_AUTH],
            {"commonName": "gearcomp test user"},
        )
        cert_der = uacrypto.der_from_x509(await uacrypto.load_certificate(user_cert))

    server = Server(user_manager=Users(args.user, password, cert_der))
    await server.init()
    server.set_endpoint(f"opc.tcp://127.0.0.1:{args.port}/")
    server.set_server_name("gearcomp asyncua test CNC")
    await server.set_application_uri("urn:gearcomp-asyncua-cnc-server")
    if args.secure:
        server.set_security_policy(
            [
                ua.SecurityPolicyType.Basic256Sha256_Sign,
                ua.SecurityPolicyType.Basic256Sha256_SignAndEncrypt,
            ]
        )
        server.set_identity_tokens([ua.UserNameIdentityToken, ua.X509IdentityToken])
        await server.load_certificate(str(server_cert))
        await server.load_private_key(str(d / "server_key.pem"))
    else:
        server.set_security_policy([ua.SecurityPolicyType.NoSecurity])
        server.set_identity_tokens([ua.AnonymousIdentityToken])

    ns = await server.register_namespace(NS_URI)
    objects = server.nodes.objects
    V = ua.VariantType
    spec = [
        ("Temp.A", 20.0, V.Double, False),
        ("Temp.B", 20.0, V.Double, False),
        ("Comp.D", 0.0, V.Double, True),
        ("Comp.F", 0.0, V.Float, True),
        ("Comp.I16", 0, V.Int16, True),
        ("Comp.I32", 0, V.Int32, True),
        ("Comp.RO", 0.0, V.Double, False),
        ("Hold", False, V.Boolean, True),
        ("Beat", 0, V.Int16, True),
    ]
    nodes = {}
    for name, value, vt, writable in spec:
        var = await objects.add_variable(ua.NodeId(name, ns), name, ua.Variant(value, vt))
        if writable:
            await var.set_writable()
        nodes[name] = (var, writable)

    async with server:
        emit(
            {
                "ready": True,
                "ns": ns,
                "server_cert": str(server_cert),
                "user_cert": str(user_cert),
                "user_key": str(user_key),
            }
        )
        loop = asyncio.get_running_loop()
        reader = asyncio.StreamReader()
        await loop.connect_read_pipe(lambda: asyncio.StreamReaderProtocol(reader), sys.stdin)

        async def commands():
            while True:
                line = await reader.readline()
                if not line:
                    os._exit(0)
                parts = line.decode().split()
                if len(parts) == 3 and parts[0] == "set" and parts[1] in nodes:
                    var = nodes[parts[1]][0]
                    await var.write_value(ua.Variant(float(parts[2]), V.Double))

        task = asyncio.create_task(commands())
        last = {}
        while not task.done():
            for name, (var, writable) in nodes.items():
                if not writable:
                    continue
                dv = await var.read_data_value()
                v = dv.Value
                key = (v.Value, v.VariantType.name)
                if last.get(name) != key:
                    last[name] = key
                    emit({"node": name, "value": v.Value, "type": v.VariantType.name})
            await asyncio.sleep(0.01)


if __name__ == "__main__":
    asyncio.run(main())
