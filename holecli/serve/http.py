"""``holecli serve``'s HTTP/JSON front end (FastAPI): measure, fetch results, health, metrics.

Every route translates HTTP into a :class:`holecli.serve.service.MeasureRequest` (or a store query)
and a :class:`holecli.serve.service.ServiceError` into its status with one JSON body,
``{"error": {"status": 404, "code": "not_found", "message": "..."}}``. Malformed requests (a body that
is not the JSON asked for, a query value of the wrong type) are 400, not FastAPI's usual 422, which
here means a scan that cannot be measured.

The OpenAPI document is at ``/openapi.json``; the interactive pages (``/docs``) are off: they load
their scripts from a CDN, which a shop-floor network does not reach.
"""

from __future__ import annotations

from typing import Any, Dict, List, Literal, Optional

from fastapi import FastAPI, Query, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse, Response
from pydantic import BaseModel, ConfigDict, Field, ValidationError
from starlette.exceptions import HTTPException as StarletteHTTPException

from holecli.io.formats import INPUT_FORMATS
from holecli.serve.security import token_matches
from holecli.serve.service import OPTIONS, MeasureRequest, ServiceError

__all__ = ["MeasureBody", "create_app"]

_ERROR = {"description": "The request is refused: {error: {status, code, message}}",
          "content": {"application/json": {"schema": {"$ref": "#/components/schemas/ErrorBody"}}}}


class MeasureBody(BaseModel):
    """``POST /v1/measure`` with ``Content-Type: application/json``: a scan the service may read."""

    model_config = ConfigDict(extra="forbid")
    path: str = Field(description="The scan: absolute, or relative to the first --allow-dir folder.",
                      min_length=1, max_length=4096)
    format: Optional[Literal[INPUT_FORMATS]] = Field(  # type: ignore[valid-type]
        None, description="Read the file in this format, whatever its extension.")
    options: Dict[str, Any] = Field(
        default_factory=dict, description="Detection options: " + "; ".join(f"{k}: {v}" for k, v in OPTIONS.items()))
    spec: Optional[str] = Field(None, description="A spec name in --spec-dir (NAME.toml).", max_length=100)
    registration: Optional[str] = Field(None, description="A registration name in --spec-dir (NAME.json).",
                                        max_length=100)
    meta: Dict[str, Optional[str]] = Field(default_factory=dict,
                                           description="part, serial, cell, operator: what the store files it under.")


class ErrorDetail(BaseModel):
    status: int
    code: str
    message: str


class ErrorBody(BaseModel):
    error: ErrorDetail


def _error(status, message):
    error = ServiceError(status, message)
    return JSONResponse({"error": {"status": error.status, "code": error.code, "message": error.message}},
                        status_code=error.status)


def _validation_message(errors):
    parts = []
    for error in errors[:3]:
        where = ".".join(str(item) for item in error.get("loc", ()) if item != "body")
        parts.append(f"{where}: {error.get('msg', 'invalid')}" if where else str(error.get("msg", "invalid")))
    return "; ".join(parts)[:500] or "malformed request"


def create_app(service, token=None) -> FastAPI:
    """The FastAPI application of ``service``.

    Parameters
    ----------
    service : holecli.serve.service.Service
    token : str, optional
        Every request but ``GET /v1/health`` must carry ``Authorization: Bearer <token>``.

    Returns
    -------
    fastapi.FastAPI
    """
    app = FastAPI(title="holecli serve", version=service.version, docs_url=None, redoc_url=None,
                  description="Measure drilled holes in 3D scans: the record `holecli detect` writes, stored.")

    @app.middleware("http")
    async def bearer_token(request: Request, call_next):
        if token is not None and request.url.path != "/v1/health" \
                and not token_matches(request.headers.get("authorization"), token):
            return _error(401, "this service asks for a bearer token (Authorization: Bearer <token>)")
        return await call_next(request)

    @app.exception_handler(ServiceError)
    async def service_error(request: Request, error: ServiceError):
        return _error(error.status, error.message)

    @app.exception_handler(RequestValidationError)
    async def malformed(request: Request, error: RequestValidationError):
        return _error(400, _validation_message(error.errors()))

    @app.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, error: StarletteHTTPException):
        return _error(error.status_code, str(error.detail))

    measure_body = {
        "required": True,
        "content": {
            "application/json": {"schema": MeasureBody.model_json_schema(ref_template="#/components/schemas/{model}")},
            "application/octet-stream": {"schema": {"type": "string", "format": "binary"}},
        },
    }

    @app.post("/v1/measure", summary="Measure a scan: a file the service may read, or the cloud itself",
              openapi_extra={"requestBody": measure_body},
              responses={200: {"description": "The record holecli detect writes, with id, received, processing_ms, "
                                              "stored and meta"},
                         400: _ERROR, 401: _ERROR, 403: _ERROR, 404: _ERROR, 408: _ERROR, 413: _ERROR, 422: _ERROR,
                         503: _ERROR})
    async def measure(request: Request,
                      format: Optional[Literal[INPUT_FORMATS]] = Query(  # type: ignore[valid-type]
                          None, description="The uploaded scan's format (a raw body)."),
                      spec: Optional[str] = Query(None, max_length=100),
                      registration: Optional[str] = Query(None, max_length=100),
                      part: Optional[str] = Query(None, max_length=200),
                      serial: Optional[str] = Query(None, max_length=200),
                      cell: Optional[str] = Query(None, max_length=200),
                      operator: Optional[str] = Query(None, max_length=200),
                      method: Optional[Literal["robust", "paper"]] = Query(None),
                      min_diameter: Optional[float] = Query(None, gt=0),
                      max_holes: Optional[int] = Query(None, ge=1, le=2**31),
                      full_only: Optional[bool] = Query(None),
                      gauge_depth: Optional[float] = Query(None, gt=0),
                      units: Optional[Literal["mm", "m", "in"]] = Query(None),
                      output_units: Optional[Literal["mm", "m", "in"]] = Query(None),
                      scan: Optional[int] = Query(None, ge=0, le=2**31),
                      explain: Optional[bool] = Query(None)):
        content_type = request.headers.get("content-type", "").split(";")[0].strip().lower()
        if content_type == "application/json":
            data = await _body(request, service.max_upload_bytes)
            try:
                body = MeasureBody.model_validate_json(data)
            except ValidationError as error:
                raise ServiceError(400, _validation_message(error.errors())) from None
            measure_request = MeasureRequest(path=body.path, format=body.format, options=body.options, spec=body.spec,
                                             registration=body.registration, meta=body.meta, channel="http")
        else:
            if format is None:
                raise ServiceError(400, "an uploaded scan needs ?format= (" + ", ".join(INPUT_FORMATS) + "), or send "
                                        "Content-Type: application/json with a path")
            data = await _body(request, service.max_upload_bytes)
            options = {name: value for name, value in (
                ("method", method), ("min_diameter", min_diameter), ("max_holes", max_holes), ("full_only", full_only),
                ("gauge_depth", gauge_depth), ("units", units), ("output_units", output_units), ("scan", scan),
                ("explain", explain)) if value is not None}
            meta = {name: value for name, value in (("part", part), ("serial", serial), ("cell", cell),
                                                    ("operator", operator)) if value is not None}
            measure_request = MeasureRequest(upload=data, format=format, options=options, spec=spec,
                                             registration=registration, meta=meta, channel="http")
        return JSONResponse(await service.measure(measure_request))

    @app.get("/v1/results/{result_id}", summary="A stored measurement, as it was answered",
             responses={400: _ERROR, 404: _ERROR})
    async def result(result_id: str):
        return JSONResponse(await service.result(result_id))

    @app.get("/v1/results", summary="The stored measurements that match, newest first (summaries)",
             responses={400: _ERROR})
    async def results(part: Optional[str] = Query(None, max_length=200),
                      serial: Optional[str] = Query(None, max_length=200),
                      since: Optional[str] = Query(None, max_length=40, description="ISO-8601 date or time (UTC)"),
                      until: Optional[str] = Query(None, max_length=40, description="ISO-8601 date or time (UTC)"),
                      verdict: Optional[Literal["pass", "fail", "undecided", "unchecked", "error"]] = Query(None),
                      limit: int = Query(100, ge=1, le=10000)) -> List[dict]:
        return JSONResponse(await service.results(part=part, serial=serial, since=since, until=until, verdict=verdict,
                                                  limit=limit))

    @app.get("/v1/health", summary="Whether the service is up: its version, workers and queue")
    async def health():
        return JSONResponse(service.health())

    @app.get("/metrics", summary="Prometheus text: requests, errors, latency, queue depth",
             response_class=Response)
    async def metrics():
        from holecli.serve.metrics import CONTENT_TYPE

        if service.metrics is None:
            raise ServiceError(404, "this service keeps no metrics")
        return Response(service.metrics.text(), media_type=CONTENT_TYPE)

    generated = app.openapi

    def openapi():
        """The generated document, with the error body the responses refer to."""
        if app.openapi_schema is None:
            schemas = generated().setdefault("components", {}).setdefault("schemas", {})
            schemas["ErrorDetail"] = ErrorDetail.model_json_schema()
            body = ErrorBody.model_json_schema(ref_template="#/components/schemas/{model}")
            body.pop("$defs", None)
            schemas["ErrorBody"] = body
        return app.openapi_schema

    app.openapi = openapi
    return app


async def _body(request, limit):
    """The request's body, refused (413) past ``limit`` bytes without reading the rest."""
    declared = request.headers.get("content-length")
    if declared is not None and declared.isdigit() and int(declared) > limit:
        raise ServiceError(413, f"the body is larger than {limit} bytes (--max-upload-mb)")
    chunks, size = [], 0
    async for chunk in request.stream():
        size += len(chunk)
        if size > limit:
            raise ServiceError(413, f"the body is larger than {limit} bytes (--max-upload-mb)")
        chunks.append(chunk)
    return b"".join(chunks)
