"""The web page at / and the API docs at /docs, every script they load served from here (no CDN): Plotly from the
`plotly` package, Swagger UI 5 (OpenAPI 3.1) from `fastapi-offline`. The page (static/) talks only to /v1."""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

from fastapi import APIRouter, FastAPI
from fastapi.openapi.docs import get_swagger_ui_html
from fastapi.responses import FileResponse, HTMLResponse
from fastapi.staticfiles import StaticFiles

__all__ = ["STATIC_DIR", "mount_assets", "router"]

STATIC_DIR = Path(__file__).resolve().parents[1] / "static"
SWAGGER_URL = "/vendor/swagger-ui"

router = APIRouter(include_in_schema=False)


def _shipped(package: str, folder: str, name: str) -> Path:
    """A file a package ships, or why the service cannot start."""
    path = Path(str(files(package) / folder / name))
    if not path.is_file():
        raise RuntimeError(f"the {package} package has no {path}: reinstall raydamp[service]")
    return path


def _plotly_js() -> Path:
    return _shipped("plotly", "package_data", "plotly.min.js")


@router.get("/", response_class=FileResponse)
def page() -> FileResponse:
    return FileResponse(STATIC_DIR / "index.html", media_type="text/html")


@router.get("/vendor/plotly.min.js", response_class=FileResponse)
def plotly_js() -> FileResponse:
    # The file changes only with the package: a day's caching spares reloading 4 MB.
    return FileResponse(_plotly_js(), media_type="text/javascript", headers={"Cache-Control": "max-age=86400"})


@router.get("/docs", response_class=HTMLResponse)
def docs() -> HTMLResponse:
    return get_swagger_ui_html(openapi_url="/openapi.json", title="raydamp API",
                               swagger_js_url=f"{SWAGGER_URL}/swagger-ui-bundle.js",
                               swagger_css_url=f"{SWAGGER_URL}/swagger-ui.css",
                               swagger_favicon_url=f"{SWAGGER_URL}/favicon.png",
                               # Swagger UI's default sends the spec to validator.swagger.io for a badge.
                               swagger_ui_parameters={"validatorUrl": None})


def mount_assets(app: FastAPI) -> None:
    """The page's files under /static, Swagger UI's under /vendor/swagger-ui; a missing asset stops the start."""
    _plotly_js()
    app.mount("/static", StaticFiles(directory=STATIC_DIR), name="static")
    swagger = _shipped("fastapi_offline", "static", "swagger-ui-bundle.js").parent
    app.mount(SWAGGER_URL, StaticFiles(directory=swagger), name="swagger-ui")
