/* The site's search runs in a web worker, and a page opened from disk (file://) may not start one.
 * Opened from disk, this file replaces Worker with a hidden iframe that runs the worker's script:
 * messages go to the iframe's window as "message" events, and the script's postMessage calls come
 * back as this object's "message" events. Served over HTTP, the browser's own Worker is kept. */
(function () {
  "use strict";
  if (window.location.protocol !== "file:") return;

  var relays = {};
  var count = 0;
  window.__frameWorkerRelay = function (id, data) {
    var worker = relays[id];
    if (worker) setTimeout(function () { worker._deliver(data); }, 0);
  };

  function FrameWorker(url) {
    var target = document.createElement("span");  // an EventTarget the page's listeners attach to
    var id = String(++count);
    var frame = document.createElement("iframe");
    var self = this;
    this._target = target;
    this.onmessage = null;
    this.onerror = null;
    this._frame = frame;
    relays[id] = this;
    frame.hidden = true;
    (document.body || document.documentElement).appendChild(frame);
    this._ready = new Promise(function (resolve) { frame.addEventListener("load", resolve); });
    var doc = frame.contentWindow.document;
    doc.open();
    doc.write("<!DOCTYPE html><html><body><script>" +
      "postMessage=function(data){parent.__frameWorkerRelay(" + JSON.stringify(id) + ",data)};" +
      "importScripts=function(){throw new Error('importScripts is not available from file://')};" +
      "</scr" + "ipt><script src=" + JSON.stringify(String(url)) + "></scr" + "ipt></body></html>");
    doc.close();
    this._deliver = function (data) {
      var event = new MessageEvent("message", { data: data });
      target.dispatchEvent(event);
      if (typeof self.onmessage === "function") self.onmessage(event);
    };
  }
  FrameWorker.prototype.postMessage = function (data) {
    var frame = this._frame;
    this._ready.then(function () {
      if (frame.contentWindow) frame.contentWindow.dispatchEvent(new MessageEvent("message", { data: data }));
    });
  };
  FrameWorker.prototype.terminate = function () {
    this._frame.remove();
  };
  FrameWorker.prototype.addEventListener = function (type, listener, options) {
    this._target.addEventListener(type, listener, options);
  };
  FrameWorker.prototype.removeEventListener = function (type, listener, options) {
    this._target.removeEventListener(type, listener, options);
  };
  FrameWorker.prototype.dispatchEvent = function (event) {
    return this._target.dispatchEvent(event);
  };
  window.Worker = FrameWorker;
})();
