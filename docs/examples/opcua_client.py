"""Measure a scan over holecli serve's OPC UA: python opcua_client.py SCAN [ENDPOINT]."""
import asyncio
import sys

from asyncua import Client, ua


async def main(scan, endpoint):
    async with Client(endpoint, timeout=30) as client:
        ns = await client.get_namespace_index("urn:holecli:serve")
        holecli = client.get_node(ua.NodeId("Holecli", ns))
        result_id, holes, verdict = await holecli.call_method(
            ua.QualifiedName("Measure", ns), scan, "", "part=P-7;serial=0042")
        diameters = await client.get_node(ua.NodeId("Holecli.LastResult.Diameter", ns)).read_value()
        print(result_id[:8], holes, verdict, [round(d, 4) for d in diameters])


asyncio.run(main(sys.argv[1], (sys.argv[2:] or ["opc.tcp://127.0.0.1:4840/holecli/"])[0]))
